"""Static reach (no ROS): the metrics of one executed plan, the summary per planner, the goals."""

from __future__ import annotations

import numpy as np
import pytest

from latent_planner_ros.evaluation.reach import ExecutionLog, PlanCall, path_length, reach_metrics, summarise
from latent_planner_ros.evaluation.reach_goals import GOAL_BOX, choose_goal
from latent_planner_ros.robot.limits import Q_READY
from latent_planner_ros.robot.panda import load_panda
from latent_planner_ros.robot.rotations import matrix_to_quat


def _log(q: np.ndarray, distance: np.ndarray, contact: np.ndarray) -> ExecutionLog:
    t = 0.01 * np.arange(len(q))
    return ExecutionLog(t=t, q=q, distance_t=t, distance=distance, contact_t=t, contact=contact)


def _goal(q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    tf = load_panda().fk(q)
    return tf.translation, matrix_to_quat(tf.rotation)


def test_path_length_sums_the_steps():
    assert path_length(np.array([[0.0, 0.0], [3.0, 4.0], [3.0, 5.0]])) == pytest.approx(6.0)
    assert path_length(np.zeros((1, 3))) == 0.0


def test_an_execution_ending_at_the_goal_without_contact_succeeds():
    q_goal = Q_READY + np.array([0.3, 0.2, 0.0, 0.2, 0.0, -0.1, 0.0])
    q = np.linspace(Q_READY, q_goal, 50)
    call = PlanCall("planner", True, 1.5, np.zeros((5, 3)), q, np.linspace(0.0, 2.0, 50))
    pos, quat = _goal(q_goal)
    row = reach_metrics(call, _log(q, np.full(50, 0.08), np.zeros(50, bool)), pos, quat)
    assert row["success"] and row["final_pos_err_m"] < 1e-9 and row["final_ori_err_deg"] < 1e-3
    assert row["min_distance_m"] == pytest.approx(0.08) and row["contacts"] == 0
    assert row["joint_path_rad"] == pytest.approx(np.linalg.norm(q_goal - Q_READY))
    assert row["tcp_path_m"] > 0 and row["trajectory_s"] == 2.0

    touched = np.zeros(50, bool)
    touched[20:25] = True
    assert not reach_metrics(call, _log(q, np.full(50, 0.08), touched), pos, quat)["success"]
    short = reach_metrics(call, _log(q[:25], np.full(25, 0.08), np.zeros(25, bool)), pos, quat)
    assert not short["success"] and short["final_pos_err_m"] > 0.02


def test_no_plan_is_a_failure_and_the_summary_counts_per_planner():
    pos, quat = _goal(Q_READY)
    failed = reach_metrics(
        PlanCall("ompl_planner", False, 5.0, np.zeros((0, 3)), np.zeros((0, 7)), np.zeros(0)), None, pos, quat
    )
    assert not failed["success"] and failed["final_pos_err_m"] is None
    q = np.repeat(Q_READY[None], 3, axis=0)
    ok = reach_metrics(
        PlanCall("planner", True, 1.0, np.zeros((2, 3)), q, np.arange(3.0)),
        _log(q, np.array([0.1, 0.05, 0.1]), np.zeros(3, bool)),
        pos,
        quat,
    )
    s = summarise([ok, failed])
    assert s["planner"]["successes"] == 1 and s["planner"]["min_distance_m"] == pytest.approx(0.05)
    assert s["ompl_planner"] == {**s["ompl_planner"], "runs": 1, "planned": 0, "successes": 0}


def test_a_scenario_target_is_the_goal_else_a_drawn_pose_meets_the_filters():
    shelf = choose_goal("shelf", 0)
    assert shelf.q_goal is None and np.allclose(shelf.position, [0.55, 0.0, 0.15])
    goal = choose_goal("tabletop", 0)
    assert np.all(goal.position >= GOAL_BOX[0]) and np.all(goal.position <= GOAL_BOX[1])
    assert goal.clearance_m >= 0.05
    pos, quat = _goal(goal.q_goal)
    assert np.allclose(pos, goal.position) and abs(abs(np.dot(quat, goal.quaternion_xyzw)) - 1) < 1e-9
    again = choose_goal("tabletop", 0)
    assert np.array_equal(again.q_goal, goal.q_goal)

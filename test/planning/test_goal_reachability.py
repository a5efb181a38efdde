"""Fast answers for goals the arm cannot take: below the table, beyond the reach; reachable goals pass."""

import time

import numpy as np

from latent_planner_ros.planning.goal import Goal
from latent_planner_ros.planning.goal_reachability import refused_result, unreachable_reason
from latent_planner_ros.robot.collision import CollisionChecker
from latent_planner_ros.robot.limits import Q_READY
from latent_planner_ros.robot.panda import load_panda

DOWN = np.diag([1.0, -1.0, -1.0])  # the hand pointing down


def test_goals_below_the_table_or_out_of_reach_are_refused_with_the_reason_reachable_ones_pass():
    panda, checker = load_panda(), CollisionChecker(convex=True)
    below = unreachable_reason(panda, checker, Goal(np.array([0.55, 0.25, -0.05]), DOWN), Q_READY)
    assert below.startswith("no valid IK solution") and "table collision" in below
    high = unreachable_reason(panda, checker, Goal(np.array([0.0, 0.0, 1.25]), DOWN), Q_READY)
    assert high.startswith("no IK solution: none of")
    for position in ([0.5, 0.0, 0.3], [0.3, -0.4, 0.05], [-0.4, 0.2, 0.5]):
        assert unreachable_reason(panda, checker, Goal(np.array(position), DOWN), Q_READY) == "", position
    # position-only goals (LSPP) need only a position
    loose = Goal(np.array([0.5, 0.3, 0.4]), np.eye(3), ori_tol=np.pi)
    assert unreachable_reason(panda, checker, loose, Q_READY) == ""


def test_a_refused_goal_gives_a_failed_result_at_the_start():
    panda = load_panda()
    goal = Goal(np.array([0.55, 0.25, -0.05]), DOWN)
    result = refused_result(panda, Q_READY, goal, "unreachable: below", time.perf_counter())
    assert not result.success and result.reason == "unreachable: below"
    assert result.q_path.shape == (1, 7) and np.array_equal(result.q_path[0], Q_READY)

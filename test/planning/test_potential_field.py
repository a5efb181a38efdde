"""The potential field baseline: cylinder distances, free-space reaching, avoiding a cylinder, joint limits."""

from __future__ import annotations

import math

import numpy as np
import pytest

from latent_planner_ros.data.cylinders import cylinder_scene
from latent_planner_ros.evaluation.path_check import PathJudge
from latent_planner_ros.planning.cylinder_distance import cylinder_distance
from latent_planner_ros.planning.goal import Goal
from latent_planner_ros.planning.ik import IkConfig, solve_ik
from latent_planner_ros.planning.potential_field import PotentialFieldPlanner
from latent_planner_ros.planning.potential_field_config import PotentialFieldConfig
from latent_planner_ros.planning.protocol import Planner
from latent_planner_ros.robot.limits import Q_MAX, Q_MIN, Q_READY, V_MAX
from latent_planner_ros.robot.panda import load_panda

DOWN = np.diag([1.0, -1.0, -1.0])
"""TCP pointing down, fingers along world y."""
ON_THE_LINE = np.array([[0.5, 0.0, 0.3, 0.04]])
"""A cylinder (x, y, h, r) [m] on the straight TCP line between the start and the goal below."""


@pytest.fixture(scope="module")
def planner() -> PotentialFieldPlanner:
    return PotentialFieldPlanner()


@pytest.fixture(scope="module")
def across() -> tuple[np.ndarray, Goal]:
    """Start with the TCP at (0.5, -0.3, 0.2), position-only goal at (0.5, 0.3, 0.2), any orientation."""
    start = solve_ik(load_panda(), Goal(np.array([0.5, -0.3, 0.2]), DOWN), Q_READY, IkConfig()).q
    return start, Goal(np.array([0.5, 0.3, 0.2]), np.eye(3), pos_tol=0.01, ori_tol=math.pi)


def _check_result(result, start_q: np.ndarray) -> None:
    q = result.q_path
    assert np.allclose(q[0], start_q)
    assert np.all(q >= Q_MIN) and np.all(q <= Q_MAX)
    assert np.allclose(result.ee_positions, load_panda().fk_batch(q)[0])
    assert result.times[0] == 0 and np.all(np.diff(result.times) > 0)
    assert np.all(np.abs(np.diff(q, axis=0)) / np.diff(result.times)[:, None] <= V_MAX + 1e-9)


def test_cylinder_distance_signs_directions_and_gradient(rng):
    cyl = np.array([[0.5, 0.0, 0.3, 0.05]])
    pts = np.array([[0.6, 0.0, 0.1], [0.5, 0.0, 0.5], [0.5, 0.02, 0.29], [0.6, 0.0, 0.4]])
    dist, direction = cylinder_distance(pts, cyl)
    assert dist[:, 0] == pytest.approx([0.05, 0.2, -0.01, math.hypot(0.05, 0.1)])
    assert direction[0, 0] == pytest.approx([1.0, 0.0, 0.0]) and direction[1, 0] == pytest.approx([0.0, 0.0, 1.0])
    assert direction[2, 0] == pytest.approx([0.0, 0.0, 1.0])  # 1 cm below the top, 3 cm inside the side
    outside = rng.uniform([0.3, -0.2, 0.0], [0.7, 0.2, 0.5], size=(50, 3))
    d0, n0 = cylinder_distance(outside, cyl)
    keep = d0[:, 0] > 1e-3
    eps = 1e-6
    grad = np.stack([(cylinder_distance(outside + eps * e, cyl)[0] - d0)[:, 0] / eps for e in np.eye(3)], axis=1)
    assert np.allclose(grad[keep], n0[keep, 0], atol=1e-4), "the direction is the distance's gradient outside"


def test_protocol_config_and_bad_inputs(planner):
    p: Planner = planner
    assert p.name == "potential_field"
    with pytest.raises(ValueError, match="influence"):
        PotentialFieldConfig(influence=0.0)
    with pytest.raises(ValueError, match="max_steps"):
        PotentialFieldConfig(max_steps=0)
    with pytest.raises(ValueError, match=r"\(K, 4\)"):
        planner.set_cylinders(np.zeros((2, 3)))
    with pytest.raises(ValueError, match="start_q"):
        planner.plan(np.full(7, np.nan), Goal(np.array([0.5, 0.0, 0.3]), DOWN))


def test_reaches_a_position_in_free_space_whatever_the_goal_orientation(planner, across):
    start, goal = across
    planner.set_cylinders(np.zeros((0, 4)))
    result = planner.plan(start, goal)
    assert result.success and result.reason == "reached", result.reason
    _check_result(result, start)
    verdict = PathJudge(cylinder_scene(np.zeros((0, 4)))).judge(result.q_path, goal)
    assert verdict.reached and verdict.collision == ""
    assert result.final_pos_err_m <= 0.5 * goal.pos_tol and result.final_ori_err_rad > math.radians(30)


def test_goes_around_a_cylinder_on_the_straight_path(planner, across):
    start, goal = across
    judge = PathJudge(cylinder_scene(ON_THE_LINE))
    blind = PotentialFieldPlanner(
        PotentialFieldConfig(repulsive_speed=0.0, check_collisions=False), cylinders=ON_THE_LINE
    )
    assert judge.judge(blind.plan(start, goal).q_path, goal).collision == "obstacle", "without repulsion it collides"

    planner.set_cylinders(ON_THE_LINE)
    result = planner.plan(start, goal)
    assert result.success, result.reason
    _check_result(result, start)
    verdict = judge.judge(result.q_path, goal)
    assert verdict.reached and verdict.collision == "", verdict
    assert result.info["min_sphere_clearance_m"] > 0
    print(f"around a cylinder: {result.planning_time_s:.3f} s, {len(result.q_path)} states")


def test_joint_limits_hold_when_the_goal_pulls_past_them(planner):
    start = Q_READY.copy()
    start[3] = Q_MAX[3] - 0.05  # elbow almost straight; a goal out of reach pulls it further
    planner.set_cylinders(np.zeros((0, 4)))
    result = planner.plan(start, Goal(np.array([1.2, 0.0, 0.4]), DOWN, ori_tol=math.pi))
    assert not result.success and result.reason, "out of reach: a failure with a reason"
    _check_result(result, start)
    assert result.q_path[:, 3].max() <= Q_MAX[3]
    push = planner._limit_velocity(np.where(np.arange(7) == 3, Q_MAX, 0.5 * (Q_MIN + Q_MAX)))
    assert push[3] < 0 and np.all(push[:3] == 0) and np.all(push[4:] == 0), "pushed back from the upper limit only"

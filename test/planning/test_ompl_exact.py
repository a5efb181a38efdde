"""OMPL with exact obstacle geometry (LSPP's cylinders), the exact checker, and position-only IK goals."""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin
import pytest

from latent_planner_ros.data.cylinders import CylinderRanges, cylinder_scene
from latent_planner_ros.data.labels import CollisionLabeler
from latent_planner_ros.evaluation.path_check import PathJudge
from latent_planner_ros.planning.goal import Goal
from latent_planner_ros.planning.ik import IkConfig, goal_configurations, is_position_only, solve_ik
from latent_planner_ros.planning.ompl_baseline import seed_ompl
from latent_planner_ros.planning.ompl_exact import ExactOmplPlanner
from latent_planner_ros.planning.protocol import Planner
from latent_planner_ros.planning.scene_checker import SceneChecker
from latent_planner_ros.robot.collision import CollisionChecker
from latent_planner_ros.robot.limits import Q_READY
from latent_planner_ros.robot.panda import load_panda
from latent_planner_ros.robot.sampler import FeasibleSampler

DOWN = np.diag([1.0, -1.0, -1.0])
"""TCP pointing down, fingers along world y."""
UP = np.diag([1.0, 1.0, 1.0])
"""TCP pointing up: far from the start's orientation (pointing down)."""
BLOCKER = np.array([[0.5, 0.0, 0.45, 0.06]])
"""A cylinder (x, y, h, r) [m] between the start and the goal below."""


@pytest.fixture(scope="module", autouse=True)
def _seeded_ompl():
    seed_ompl(7)  # once per process; a no-op (with OMPL's warning) if another module sampled first


@pytest.fixture(scope="module")
def across() -> tuple[np.ndarray, Goal]:
    """Start with the TCP at (0.5, -0.3, 0.2) pointing down, position-only goal at (0.5, 0.3, 0.2)."""
    start = solve_ik(load_panda(), Goal(np.array([0.5, -0.3, 0.2]), DOWN), Q_READY, IkConfig()).q
    return start, Goal(np.array([0.5, 0.3, 0.2]), UP, pos_tol=0.01, ori_tol=math.pi)


def test_scene_checker_agrees_with_the_exact_labels(rng):
    cylinders = CylinderRanges().sample(rng, 3)
    scene = cylinder_scene(cylinders)
    checker, labeler, arm = SceneChecker(scene), CollisionLabeler(scene), CollisionChecker()
    q = FeasibleSampler(rng).sample(60)
    ours = np.array([checker.is_valid(qi) for qi in q])
    reference = ~labeler.label(q).any(axis=1) & arm.feasible(q)
    assert np.array_equal(ours, reference)
    assert 0 < ours.sum() < len(q), "the sample must hold both valid and colliding states"
    assert checker.checks == len(q)
    assert checker.contains(np.array([*cylinders[0, :2], 0.5 * cylinders[0, 2]]))
    assert not checker.contains(np.array([0.0, 0.0, 1.5]))


def test_position_only_ik_reaches_the_position_in_another_orientation(across):
    start, goal = across
    assert is_position_only(goal) and not is_position_only(Goal(goal.position, UP))
    panda = load_panda()
    full = solve_ik(panda, Goal(goal.position, UP), start, IkConfig())  # a 6D goal: orientation enforced
    assert full.converged and full.ori_err < math.radians(0.5)
    sol = solve_ik(panda, goal, start, IkConfig())
    assert sol.converged and sol.pos_err < 1e-3 and sol.ori_err > math.radians(30), "orientation left free"
    tf = panda.fk(sol.q)
    assert np.linalg.norm(tf.translation - goal.position) < 1e-3
    assert sol.ori_err == pytest.approx(np.linalg.norm(pin.log3(tf.rotation.T @ UP)))
    assert np.linalg.norm(pin.log3(tf.rotation.T @ panda.fk(start).rotation)) > math.radians(5)
    search = goal_configurations(panda, goal, start, lambda q: None, IkConfig(), np.random.default_rng(3))
    assert len(search.solutions) == IkConfig().max_solutions


def test_rrtconnect_goes_around_a_cylinder_exactly(across):
    start, goal = across
    panda = load_panda()
    judge = PathJudge(cylinder_scene(BLOCKER))
    q_goal = solve_ik(panda, goal, start, IkConfig()).q
    assert judge.judge(np.stack([start, q_goal]), goal).collision == "obstacle", "the direct motion must collide"

    planner: Planner = ExactOmplPlanner()
    planner.set_cylinders(BLOCKER)
    result = planner.plan(start, goal)
    assert result.success and result.reason == "reached", result.reason
    assert np.allclose(result.q_path[0], start)
    verdict = judge.judge(result.q_path, goal)
    assert verdict.reached and verdict.collision == "", verdict
    assert result.info["obstacles"] == 1 and "octree_s" not in result.timings
    print(f"exact rrtconnect: {result.planning_time_s:.3f} s {result.timings}")


def test_goal_inside_a_cylinder_fails_with_a_reason(across):
    start, _ = across
    planner = ExactOmplPlanner(scene=cylinder_scene(BLOCKER))
    result = planner.plan(start, Goal(np.array([0.5, 0.0, 0.2]), UP, ori_tol=math.pi))
    assert not result.success and "inside an obstacle" in result.reason, result.reason


@pytest.mark.parametrize("iters", [2, 150])
@pytest.mark.parametrize("ori_tol", [math.radians(15), math.pi])
def test_ik_reports_the_errors_of_the_configuration_it_returns(iters, ori_tol, rng):
    panda = load_panda()
    for q_goal in FeasibleSampler(rng).sample(4):
        tf = panda.fk(q_goal)
        goal = Goal(tf.translation.copy(), tf.rotation.copy(), 0.01, ori_tol)
        sol = solve_ik(panda, goal, Q_READY, IkConfig(max_iters=iters))
        got = panda.fk(sol.q)
        assert sol.pos_err == pytest.approx(np.linalg.norm(got.translation - goal.position), abs=1e-12)
        assert sol.ori_err == pytest.approx(np.linalg.norm(pin.log3(got.rotation.T @ goal.rotation)), abs=1e-9)
        if sol.converged:
            assert sol.pos_err < 1e-3 and (ori_tol >= math.pi or sol.ori_err < math.radians(0.5))
        else:
            assert sol.iterations == iters

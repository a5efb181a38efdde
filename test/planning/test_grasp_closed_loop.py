"""Grasp goals in the closed loop: the target is set aside from the cloud the commands are checked against, the
arm moves only along a background plan made by plan_grasp (pre-grasp, then straight), and touches nothing."""

from __future__ import annotations

import numpy as np
import pytest

from latent_planner_ros.data.scene import Scene
from latent_planner_ros.evaluation.path_check import PathJudge
from latent_planner_ros.perception.grasp_target import split_target
from latent_planner_ros.planning.amp_ls import AmpLs, AmpLsConfig
from latent_planner_ros.planning.closed_loop import ClosedLoopConfig, ClosedLoopController
from latent_planner_ros.planning.geometric_backend import GeometricBackend
from latent_planner_ros.planning.grasp import GraspSpec, pregrasp_goal
from latent_planner_ros.planning.plan_runner import DeferredPlanRunner, planning_function
from latent_planner_ros.robot.panda import load_panda
from test.planning.test_grasp import BOARD, GOAL, OBJECT, _start, _surface

CLOUD = np.concatenate([_surface(BOARD), _surface(OBJECT)]).astype(float)


def _planner(vae) -> AmpLs:
    return AmpLs(vae, GeometricBackend(), AmpLsConfig(collision_backend="geometric"))


def _loop(vae, follow: bool = True, clearance: float = 0.01) -> ClosedLoopController:
    runner = DeferredPlanRunner(planning_function(_planner(vae))) if follow else None
    config = ClosedLoopConfig(follow_plans=follow, goal_clearance_m=clearance)
    return ClosedLoopController(_planner(vae), config, runner)


def _feed(c: ClosedLoopController, q: np.ndarray, now: float) -> None:
    """What the planner node does with each cloud: the obstacles the controller returns are the scene."""
    c.set_joint_state(q, now)
    obstacles = c.set_cloud(CLOUD, now)
    c.set_scene(obstacles, now)


def test_a_reach_goal_at_the_object_is_refused_and_a_grasp_goal_there_is_accepted(shipped_vae):
    c = _loop(shipped_vae, clearance=0.02)  # the object's faces are 1.5 cm from the TCP
    _feed(c, _start(), 0.0)
    ok, reason = c.set_goal(GOAL, 0.0)
    assert not ok and "inside an observed obstacle" in reason
    ok, reason = c.set_goal(GOAL, 0.0, GraspSpec(approach_m=0.08))
    assert ok, reason
    expected = split_target(CLOUD, GOAL.position, GOAL.rotation)
    assert len(c.cloud) == len(CLOUD) - expected.count and expected.count > 500
    assert len(c.raw_cloud) == len(CLOUD)
    assert "target points set aside" in c.grasp_note
    c.clear_goal()  # the target is an obstacle again
    assert len(c.cloud) == len(CLOUD) and c.grasp is None


def test_without_background_plans_a_grasp_goal_is_refused_with_the_reason(shipped_vae):
    c = _loop(shipped_vae, follow=False)
    _feed(c, _start(), 0.0)
    ok, reason = c.set_goal(GOAL, 0.0, GraspSpec())
    assert not ok and "follow_plans" in reason


@pytest.mark.slow
def test_the_closed_loop_reaches_a_grasp_along_its_plan_and_touches_nothing(shipped_vae):
    c = _loop(shipped_vae)
    q = _start()
    _feed(c, q, 0.0)
    assert c.set_goal(GOAL, 0.0, GraspSpec(approach_m=0.08))[0]
    states, outcomes = [q.copy()], []
    for k in range(300):
        now = 0.1 * k
        _feed(c, q, now)
        out = c.tick(now)
        outcomes.append(out)
        assert out.values.get("command_source") in ("plan", "wait", "hold"), out.reason  # never a local step
        if out.command is not None:
            q = out.command
        states.append(q.copy())
        if out.state in ("reached", "failed"):
            break
    assert out.state == "reached", out.reason
    assert c.follower.plans["followed"] >= 1
    verdict = PathJudge(Scene((BOARD, OBJECT)), table=True).judge(np.array(states), GOAL)
    assert verdict.reached and verdict.collision == "", verdict
    # the arm came in straight along the hand's z axis over the last 8 cm (the approach of plan_grasp)
    tcp = load_panda().fk_batch(np.array(states))[0]
    pre = pregrasp_goal(GOAL, 0.08).position
    tail = tcp[np.linalg.norm(tcp - pre, axis=1).argmin() :]
    assert np.linalg.norm(np.cross(tail - pre, GOAL.rotation[:, 2]), axis=1).max() < 0.011

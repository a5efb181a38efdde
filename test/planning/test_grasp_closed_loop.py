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
from latent_planner_ros.planning.goal import Goal
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


def _run(c: ClosedLoopController, q: np.ndarray, t0: float, ticks: int = 300):
    """Tick from time t0 [s] until reached or failed; returns (final q, states (T, 7), outcomes, next time)."""
    states, outcomes = [q.copy()], []
    for k in range(ticks):
        now = t0 + 0.1 * k
        _feed(c, q, now)
        out = c.tick(now)
        outcomes.append(out)
        if out.command is not None:
            q = out.command
        states.append(q.copy())
        if out.state in ("reached", "failed"):
            break
    return q, np.array(states), outcomes, t0 + 0.1 * (k + 1)


def _grasp(vae):
    """The closed loop from the start pose to GOAL as a grasp (8 cm approach), ticked until reached or failed:
    (controller, start (7,), final q, states (T, 7), outcomes, next time [s])."""
    c = _loop(vae)
    start = _start()
    _feed(c, start, 0.0)
    assert c.set_goal(GOAL, 0.0, GraspSpec(approach_m=0.08))[0]
    return c, start, *_run(c, start, 0.0)


@pytest.mark.slow
def test_the_closed_loop_reaches_a_grasp_along_its_plan_and_touches_nothing(shipped_vae):
    c, _, _, states, outcomes, _ = _grasp(shipped_vae)
    out = outcomes[-1]
    for o in outcomes:  # never a local step
        assert o.values.get("command_source") in ("plan", "wait", "hold"), o.reason
    assert out.state == "reached", out.reason
    assert c.follower.plans["followed"] >= 1
    verdict = PathJudge(Scene((BOARD, OBJECT)), table=True).judge(states, GOAL)
    assert verdict.reached and verdict.collision == "", verdict
    # the arm came in straight along the hand's z axis over the last 8 cm (the approach of plan_grasp)
    tcp = load_panda().fk_batch(states)[0]
    pre = pregrasp_goal(GOAL, 0.08).position
    tail = tcp[np.linalg.norm(tcp - pre, axis=1).argmin() :]
    assert np.linalg.norm(np.cross(tail - pre, GOAL.rotation[:, 2]), axis=1).max() < 0.011


@pytest.mark.slow
def test_a_goal_after_a_grasp_backs_the_arm_out_along_the_approach_first(shipped_vae):
    c, start, q, _, outcomes, now = _grasp(shipped_vae)
    assert outcomes[-1].state == "reached", outcomes[-1].reason
    # a reach goal back at the start's TCP pose: the grasp's target is an obstacle again
    tf = load_panda().fk(start)
    home = Goal(tf.translation.copy(), tf.rotation.copy())
    _feed(c, q, now)
    assert c.set_goal(home, now)[0]
    assert c.follower.retreating and c.follower.leaving is not None
    q, states, outcomes, _ = _run(c, q, now)
    sources = [o.values.get("command_source") for o in outcomes]
    assert outcomes[-1].state == "reached", outcomes[-1].reason
    assert sources[0] == "retreat" and c.follower.plans["retreats"] == 1
    # it backs out straight along the hand's z axis to the pre-grasp pose before anything else moves it
    backing = states[: sources.index("retreat") + sum(s == "retreat" for s in sources) + 1]
    tcp = load_panda().fk_batch(backing)[0]
    pre = pregrasp_goal(GOAL, 0.08).position
    assert np.linalg.norm(tcp[-1] - pre) < 0.005
    assert np.linalg.norm(np.cross(tcp - pre, GOAL.rotation[:, 2]), axis=1).max() < 0.011
    assert "plan" in sources[sources.index("retreat") + 1 :]  # then the new goal's plan from outside the object
    assert len(c.cloud) == len(CLOUD)  # the target is an obstacle again
    verdict = PathJudge(Scene((BOARD, OBJECT)), table=True).judge(states, home)
    assert verdict.reached and verdict.collision == "", verdict


def test_a_new_goal_away_from_the_approach_starts_no_retreat(shipped_vae):
    c = _loop(shipped_vae)
    start = _start()
    _feed(c, start, 0.0)
    pre = np.linspace(start, start + 0.3, 5)  # a kept "approach" the arm is not on
    c.follower.approach = (pre, GraspSpec(approach_m=0.08), GOAL)
    tf = load_panda().fk(start)
    assert c.set_goal(Goal(tf.translation + [0.0, 0.0, 0.05], tf.rotation.copy()), 0.0)[0]
    assert not c.follower.retreating and c.follower.approach is None  # used up
    assert len(c.cloud) == len(CLOUD)

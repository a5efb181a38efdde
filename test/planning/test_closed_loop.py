"""Closed-loop supervision: fresh inputs or hold, refused goals, the no-progress watchdog."""

import numpy as np
import pytest

from latent_planner_ros.planning.amp_ls import AmpLs, AmpLsConfig
from latent_planner_ros.planning.closed_loop import ERROR, ClosedLoopConfig, ClosedLoopController
from latent_planner_ros.planning.geometric_backend import GeometricBackend
from latent_planner_ros.planning.goal import Goal
from latent_planner_ros.robot.limits import Q_READY, V_MAX
from latent_planner_ros.robot.panda import load_panda


def _controller(vae, **cfg):
    planner = AmpLs(vae, GeometricBackend(), AmpLsConfig(collision_backend="geometric"))
    return ClosedLoopController(planner, ClosedLoopConfig(**cfg))


def _goal(dq):
    m = load_panda().fk(Q_READY + np.asarray(dq))
    return Goal(m.translation, m.rotation)


def test_inputs_missing_or_stale_mean_no_command_or_hold(shipped_vae):
    c = _controller(shipped_vae)
    out = c.tick(0.0)
    assert out.command is None and out.level == ERROR and "joint states never received" in out.reason
    c.set_joint_state(Q_READY, 0.0)
    out = c.tick(0.1)
    assert "no goal" in out.reason and out.command is None  # no command without a goal
    assert c.set_goal(_goal([0.5, 0, 0, 0, 0, 0, 0]), 0.1)[0]
    out = c.tick(0.2)
    assert "scene never received" in out.reason and np.array_equal(out.command, Q_READY)
    c.set_scene(np.zeros((0, 3)), 0.2)
    out = c.tick(0.3)
    assert out.state in ("tracking", "reached") and out.command is not None
    assert np.all(np.abs(out.command - Q_READY) <= 0.5 * V_MAX * 0.1 + 1e-9)
    out = c.tick(2.0)  # scene 1.8 s old, joint states 2 s old
    assert out.command is None and "joint states 2.00 s old" in out.reason
    c.set_joint_state(Q_READY, 2.0)
    out = c.tick(2.1)
    assert "scene 1.90 s old" in out.reason and np.array_equal(out.command, Q_READY)


def test_far_goals_and_goals_inside_obstacles_are_refused(shipped_vae):
    c = _controller(shipped_vae)
    far = Goal(np.array([3.0, 0.0, 0.5]), np.eye(3))
    ok, reason = c.set_goal(far, 0.0)
    assert not ok and "beyond the reach" in reason
    inside = _goal([0.3, 0, 0, 0, 0, 0, 0])
    c.set_scene(inside.position[None] + 0.003, 0.0, cloud=inside.position[None] + 0.003)
    ok, reason = c.set_goal(inside, 0.0)
    assert not ok and "inside an observed obstacle" in reason
    assert c.goal is None


def test_no_progress_ends_in_a_reported_failure(shipped_vae):
    c = _controller(shipped_vae, no_progress_s=1.0)
    goal = _goal([0.8, 0.3, 0.0, 0.4, 0.0, 0.0, 0.0])
    c.set_joint_state(Q_READY, 0.0)
    c.set_scene(np.zeros((0, 3)), 0.0)
    c.set_goal(goal, 0.0)
    now, out = 0.0, None
    for _ in range(40):  # the arm never moves: no progress is possible after the first ticks
        now += 0.1
        c.set_joint_state(Q_READY, now)
        c.set_scene(np.zeros((0, 3)), now)
        out = c.tick(now)
        if out.state == "failed":
            break
    assert out is not None and out.state == "failed" and "no progress" in out.reason
    assert np.array_equal(out.command, Q_READY)  # holds


def test_a_tracked_moving_goal_does_not_trip_the_watchdog(shipped_vae):
    c = _controller(shipped_vae, no_progress_s=1.0)
    goal = _goal([0.3, 0.2, 0.0, 0.2, 0.0, 0.0, 0.0])
    q, now = Q_READY.copy(), 0.0
    c.set_joint_state(q, now)
    c.set_scene(np.zeros((0, 3)), now)
    states = []
    for _ in range(60):  # the goal drifts 1 cm/s along y; the arm follows the commands exactly
        now += 0.1
        moving = Goal(goal.position + np.array([0.0, 0.01 * now, 0.0]), goal.rotation)
        c.set_goal(moving, now)
        c.set_joint_state(q, now)
        c.set_scene(np.zeros((0, 3)), now)
        out = c.tick(now)
        states.append(out.state)
        q = out.command
    assert "failed" not in states and "reached" in states[-20:], states


def test_a_goal_that_turns_back_turns_its_velocity_estimate_at_once(shipped_vae):
    base = _goal([0.3, 0, 0, 0, 0, 0, 0])
    c = _controller(shipped_vae, goal_lead_s=0.3, goal_lead_max_m=0.1)
    v = np.array([0.0, 0.15, 0.0])  # [m/s], a fast belt that bounces at t = 0.8 s
    for k in range(12):
        t = 0.08 * k
        y = v * t if t <= 0.8 else v * (1.6 - t)
        c.set_goal(Goal(base.position + y, base.rotation), t)
    np.testing.assert_allclose(c.goal_velocity(), -v, atol=1e-9)  # one goal after the turn, not 0.3 s later
    assert c.chased_goal().position[1] < c.goal.position[1]
    still = _controller(shipped_vae, goal_lead_s=0.3, goal_lead_max_m=0.1)
    rng = np.random.default_rng(0)
    for k in range(8):  # a still goal's jitter of 0.5 mm is no turn: the window keeps its goals
        still.set_goal(Goal(base.position + rng.normal(0.0, 0.0005, 3), base.rotation), 0.08 * k)
    assert len(still._goal_track) >= 4


def test_goal_lead_chases_where_a_moving_goal_will_be(shipped_vae):
    base = _goal([0.3, 0, 0, 0, 0, 0, 0])
    c = _controller(shipped_vae, goal_lead_s=0.5, goal_lead_max_m=0.1)
    v = np.array([0.0, 0.06, 0.0])  # [m/s], a belt
    for k in range(8):
        t = 0.08 * k
        assert c.set_goal(Goal(base.position + v * t, base.rotation), t)[0]
    np.testing.assert_allclose(c.goal_velocity(), v, atol=1e-9)
    np.testing.assert_allclose(c.chased_goal().position, c.goal.position + 0.5 * v, atol=1e-9)
    np.testing.assert_array_equal(c.chased_goal().rotation, base.rotation)
    fast = _controller(shipped_vae, goal_lead_s=0.5, goal_lead_max_m=0.02)
    for k in range(8):
        fast.set_goal(Goal(base.position + v * 0.08 * k, base.rotation), 0.08 * k)
    assert np.linalg.norm(fast.chased_goal().position - fast.goal.position) == pytest.approx(0.02)
    # a jump is a new goal: no velocity from the jump itself; with lead 0, or a still goal, the goal is chased
    c.set_goal(Goal(base.position + [0.0, -0.2, 0.0], base.rotation), 0.7)
    np.testing.assert_array_equal(c.goal_velocity(), np.zeros(3))
    np.testing.assert_allclose(c.chased_goal().position, c.goal.position)
    for k in range(3):  # the clock went back (a simulator reset): the estimate restarts
        c.set_goal(Goal(base.position + [0.0, -0.2 + 0.01 * k, 0.0], base.rotation), 0.8 + 0.08 * k)
    c.set_goal(Goal(base.position + [0.0, -0.17, 0.0], base.rotation), 0.1)
    c.set_goal(Goal(base.position + [0.0, -0.164, 0.0], base.rotation), 0.2)
    np.testing.assert_allclose(c.goal_velocity(), [0.0, 0.06, 0.0], atol=1e-9)
    off = _controller(shipped_vae, goal_lead_s=0.0)
    for k in range(8):
        off.set_goal(Goal(base.position + v * 0.08 * k, base.rotation), 0.08 * k)
    assert off.chased_goal() is off.goal
    still = _controller(shipped_vae)  # the default lead
    for k in range(8):
        still.set_goal(Goal(base.position, base.rotation), 0.08 * k)
    np.testing.assert_allclose(still.chased_goal().position, base.position)
    with pytest.raises(ValueError, match="goal_lead_s"):
        ClosedLoopConfig(goal_lead_s=float("nan"))


def test_goal_lead_is_not_applied_beyond_reach(shipped_vae):
    c = _controller(shipped_vae, goal_lead_s=1.0, goal_lead_max_m=0.1, reach_m=1.0)
    edge = np.array([0.0, 0.99, 0.333])  # 0.99 m from the shoulder, moving outwards at 0.1 m/s
    for k in range(5):
        assert c.set_goal(Goal(edge + [0.0, 0.002 * k, 0.0], np.eye(3)), 0.02 * k)[0]
    assert c.chased_goal() is c.goal

"""The joint command interface: refusal, clamping, interpolation over the period, velocity limit, hold."""

from __future__ import annotations

import numpy as np

from latent_planner_ros.robot.limits import Q_MAX, Q_MIN, Q_READY, V_MAX
from sim_bridge.command import JointCommand

DT = 0.002


def run(cmd: JointCommand, t0: float, seconds: float) -> tuple[float, np.ndarray]:
    """Advance for `seconds`; returns the end time and the setpoints (n, 7)."""
    points = []
    t = t0
    for _ in range(round(seconds / DT)):
        points.append(cmd.advance(t, DT).copy())
        t += DT
    return t, np.array(points)


def test_nan_and_bad_shape_are_refused_and_the_target_kept():
    cmd = JointCommand(Q_READY)
    bad = Q_READY.copy()
    bad[2] = np.nan
    result = cmd.set(bad, 0.0)
    assert not result.accepted and "panda_joint3" in result.reason
    assert not cmd.set(np.zeros(6), 0.0).accepted
    np.testing.assert_array_equal(cmd.target, Q_READY)


def test_out_of_limit_targets_are_clamped_never_exceeded():
    cmd = JointCommand(Q_READY, period=0.0, timeout=0.0)
    wild = Q_MAX + 1.0
    result = cmd.set(wild, 0.0)
    assert result.accepted and result.clamped and "panda_joint1" in result.reason
    _, sp = run(cmd, 0.0, 4.0)
    assert np.all(sp <= Q_MAX + 1e-12) and np.all(sp >= Q_MIN - 1e-12)
    np.testing.assert_allclose(sp[-1], Q_MAX)


def test_setpoint_moves_linearly_over_the_period():
    cmd = JointCommand(Q_READY, period=0.1)
    goal = Q_READY + 0.05
    cmd.set(goal, 0.0)
    _, sp = run(cmd, 0.0, 0.2)
    np.testing.assert_allclose(sp[24], Q_READY + 0.05 * 25 * DT / 0.1, atol=1e-12)  # halfway at 50 ms
    np.testing.assert_allclose(sp[49], goal, atol=1e-12)  # there after one period
    np.testing.assert_allclose(sp[-1], goal, atol=1e-12)


def test_velocity_limit_and_scale():
    for scale in (1.0, 0.5):
        cmd = JointCommand(Q_READY, period=0.1, velocity_scale=scale)
        cmd.set(np.clip(Q_READY + 2.0, Q_MIN, Q_MAX), 0.0)
        _, sp = run(cmd, 0.0, 0.5)
        speed = np.abs(np.diff(sp, axis=0)) / DT
        assert np.all(speed <= scale * V_MAX + 1e-9)
        assert np.allclose(speed.max(axis=0)[:4], scale * V_MAX[:4])


def test_holds_without_fresh_commands():
    cmd = JointCommand(Q_READY, period=0.0, timeout=0.2)
    cmd.set(np.clip(Q_READY + 2.0, Q_MIN, Q_MAX), 0.0)
    t, sp = run(cmd, 0.0, 1.0)
    stop = sp[round(0.2 / DT) + 1]
    np.testing.assert_allclose(sp[-1], stop)  # stopped where it was when the command went stale
    np.testing.assert_allclose(np.abs(stop - Q_READY), V_MAX * 0.2, atol=2 * DT * V_MAX.max())
    never = JointCommand(Q_READY, period=0.0, timeout=0.0)
    never.set(Q_READY + 0.3, 0.0)
    _, sp = run(never, 0.0, 1.0)
    np.testing.assert_allclose(sp[-1], Q_READY + 0.3)  # timeout 0: the last target is kept

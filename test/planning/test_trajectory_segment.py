"""Closed-loop segments: each starts from the commanded state, so replacements every 0.1 s stay smooth."""

import numpy as np
import pytest

from latent_planner_ros.planning.motion_limits import MotionLimits
from latent_planner_ros.planning.trajectory_segment import segment_to_target
from latent_planner_ros.robot.limits import Q_READY

DT = 1e-3
PERIOD = 0.1


def test_segments_replacing_each_other_every_period_are_continuous_and_within_limits(rng):
    limits = MotionLimits()
    q, dq, ddq = Q_READY.copy(), np.zeros(7), np.zeros(7)
    direction = rng.normal(size=7)
    direction /= np.linalg.norm(direction)
    executed = []
    for k in range(30):  # a target moving ahead of the arm, then stopping
        target = Q_READY + 0.04 * min(k + 1, 20) * direction + 0.02 * np.sin(0.5 * k)
        seg = segment_to_target(q, dq, ddq, target, limits, min_duration=2 * PERIOD, dt=DT)
        np.testing.assert_allclose(seg.positions[0], q, atol=1e-12)
        np.testing.assert_allclose(seg.velocities[0], dq, atol=1e-9)
        np.testing.assert_allclose(seg.accelerations[0], ddq, atol=1e-9)
        n = int(round(PERIOD / DT))  # replaced after one period (or ended earlier: then at rest on target)
        if seg.duration < PERIOD:
            tail = np.repeat(seg.positions[-1:], n + 1 - len(seg.times), axis=0)
            executed.append(np.concatenate([seg.positions, tail])[:n])
            q, dq, ddq = seg.positions[-1], np.zeros(7), np.zeros(7)
        else:
            assert seg.times[n] == pytest.approx(PERIOD)
            executed.append(seg.positions[:n])
            q, dq, ddq = seg.positions[n], seg.velocities[n], seg.accelerations[n]
    positions = np.concatenate(executed + [q[None]])
    velocity = np.diff(positions, axis=0) / DT
    acceleration = np.diff(positions, n=2, axis=0) / DT**2
    jerk = np.diff(positions, n=3, axis=0) / DT**3
    assert np.all(np.abs(velocity) <= limits.v_max * (1 + 1e-3))
    assert np.all(np.abs(acceleration) <= limits.a_max * (1 + 1e-3))
    assert np.all(np.abs(jerk) <= limits.j_max * (1 + 1e-3) + 1e-3)  # continuous acceleration across replacements
    assert np.abs(np.diff(velocity, axis=0)).max() <= limits.a_max.max() * DT * 1.01  # no velocity jump
    assert np.linalg.norm(velocity, axis=1)[len(velocity) // 2] > 0.1  # moving, not stopping at every target


def test_a_segment_ends_at_rest_on_the_target_and_a_step_from_rest_is_straight():
    target = Q_READY + 0.1
    seg = segment_to_target(Q_READY, np.zeros(7), np.zeros(7), target)
    np.testing.assert_allclose(seg.positions[-1], target, atol=1e-8)
    assert not np.any(seg.velocities[-1]) and seg.duration >= 0.2
    assert seg.max_deviation_rad < 1e-6


def test_bad_states_are_refused():
    with pytest.raises(ValueError, match="finite"):
        segment_to_target(Q_READY, np.full(7, np.nan), np.zeros(7), Q_READY)


def test_a_moving_target_is_passed_at_its_velocity_and_the_arm_keeps_up():
    """With v_target (the planner's targets moving at 0.3 rad/s on one joint), the arm passes each target at that
    velocity one period later instead of stopping at it, and would stop within the limits if no segment followed."""
    limits = MotionLimits()
    q, dq, ddq = Q_READY.copy(), np.zeros(7), np.zeros(7)
    v = np.zeros(7)
    v[3] = 0.3
    lag = []
    for k in range(30):
        target = Q_READY + v * PERIOD * (k + 1)
        seg = segment_to_target(q, dq, ddq, target, limits, min_duration=PERIOD, dt=DT, v_target=v)
        np.testing.assert_allclose(seg.positions[0], q, atol=1e-12)
        np.testing.assert_allclose(seg.velocities[0], dq, atol=1e-9)
        assert np.all(np.abs(seg.velocities) <= limits.v_max + 1e-9)
        assert np.all(np.abs(seg.accelerations) <= limits.a_max + 1e-6)
        np.testing.assert_allclose(seg.velocities[-1], 0.0, atol=1e-9)  # a planner that stops leaves it at rest
        i = int(round(PERIOD / DT))
        q, dq, ddq = seg.positions[i], seg.velocities[i], seg.accelerations[i]
        lag.append(float(np.abs(target - q).max()))
    assert max(lag[-10:]) < 0.005  # keeps up with the targets once up to speed (at rest on each: 0.015+)
    np.testing.assert_allclose(dq[3], 0.3, atol=0.01)

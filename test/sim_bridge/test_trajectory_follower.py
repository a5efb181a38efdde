"""TrajectoryFollower: JTC-like start stamps, replacement from the commanded state, interpolation, hold."""

import numpy as np
import pytest

from latent_planner_ros.nodes.segment_chain import state_at
from latent_planner_ros.planning.motion_limits import MotionLimits
from latent_planner_ros.planning.trajectory_segment import segment_to_target
from latent_planner_ros.robot.limits import Q_MAX, Q_READY
from sim_bridge.trajectory_follower import TrajectoryFollower, limit_violation


def test_holds_before_the_first_trajectory_and_after_the_end():
    f = TrajectoryFollower(Q_READY)
    np.testing.assert_array_equal(f.sample(3.0)[0], Q_READY)
    assert f.set_trajectory([1.0], [Q_READY + 0.2], now=3.0) == ""
    q, dq = f.sample(3.5)
    np.testing.assert_allclose(q, Q_READY + 0.1)  # linear from the commanded state to the only point
    np.testing.assert_allclose(dq, 0.2)
    q, dq = f.sample(10.0)
    np.testing.assert_allclose(q, Q_READY + 0.2) and np.testing.assert_array_equal(dq, 0)


def test_a_future_stamp_replaces_the_current_trajectory_only_at_its_start():
    f = TrajectoryFollower(Q_READY)
    f.set_trajectory([0.0, 2.0], [Q_READY, Q_READY + 1.0], now=0.0)
    f.sample(0.0)  # the sim steps: the first trajectory starts
    assert f.set_trajectory([0.5], [Q_READY], stamp=1.0, now=0.2) == ""
    np.testing.assert_allclose(f.sample(0.9)[0], Q_READY + 0.45)  # still the first one
    np.testing.assert_allclose(f.sample(1.0)[0], Q_READY + 0.5)
    np.testing.assert_allclose(f.sample(1.25)[0], Q_READY + 0.25)  # from the commanded state to the new point
    np.testing.assert_allclose(f.sample(1.5)[0], Q_READY)


def test_a_stamp_far_ahead_of_the_sim_clock_is_refused_with_the_likely_cause():
    """A sender on the wall clock stamps ~1.7e9 s against a sim clock near 0: the trajectory would wait for ever."""
    f = TrajectoryFollower(Q_READY)
    reason = f.set_trajectory([0.5], [Q_READY + 0.1], stamp=1.7e9, now=12.0)
    assert "ahead of the sim's clock" in reason and "use_sim_time" in reason
    np.testing.assert_allclose(f.sample(12.5)[0], Q_READY)  # still holding
    assert f.set_trajectory([0.5], [Q_READY + 0.1], stamp=13.0, now=12.0) == ""  # a second ahead: queued


def test_a_segment_stamped_before_its_receipt_joins_where_the_running_one_is():
    """The planner stamps a segment with its tick's time, at which its chain took the running segment's state; a
    segment received later is sampled from the receipt on along its own timeline, so the command keeps its
    direction (with stamp 0 it started over at its first point, behind where the command already was)."""
    limits = MotionLimits()
    f = TrajectoryFollower(Q_READY)
    first = segment_to_target(Q_READY, np.zeros(7), np.zeros(7), Q_READY + 0.3, limits, min_duration=0.2, dt=0.02)
    assert f.set_trajectory(first.times, first.positions, first.velocities, first.accelerations, now=0.0) == ""
    f.sample(0.0)
    t_tick, delay = 0.3, 0.06
    q, dq, ddq = state_at(first, t_tick)  # what the planner's chain starts the next segment from
    second = segment_to_target(q, dq, ddq, Q_READY + 0.6, limits, min_duration=0.2, dt=0.02)
    f.sample(t_tick + delay - 0.002)
    q_before = f.sample(t_tick + delay)[0]
    assert (
        f.set_trajectory(
            second.times, second.positions, second.velocities, second.accelerations, stamp=t_tick, now=t_tick + delay
        )
        == ""
    )
    moves = np.diff([f.sample(t_tick + delay + k * 0.002)[0] for k in range(0, 20)], axis=0)
    assert np.all(moves >= -1e-9), "the command went back"
    assert np.all(f.sample(t_tick + delay + 0.002)[0] >= q_before - 1e-9)


def test_segments_replacing_each_other_give_a_continuous_velocity():
    limits = MotionLimits()
    f = TrajectoryFollower(Q_READY)
    dt, period, now = 0.002, 0.1, 0.0
    q, dq, ddq = Q_READY, np.zeros(7), np.zeros(7)
    samples = []
    for k in range(20):
        seg = segment_to_target(q, dq, ddq, Q_READY + 0.05 * (k + 1), limits, min_duration=2 * period, dt=0.01)
        assert f.set_trajectory(seg.times, seg.positions, seg.velocities, seg.accelerations, now=now) == ""
        for t in np.arange(now, now + period - 1e-9, dt):
            samples.append(f.sample(t))
        now += period
        q, dq = f.sample(now)
        ddq = f.acceleration(now)
    velocity = np.array([s[1] for s in samples])
    assert np.abs(np.diff(velocity, axis=0)).max() <= limits.a_max.max() * dt * 1.5
    assert np.all(np.abs(velocity) <= limits.v_max * 1.05)
    assert np.linalg.norm(velocity[len(velocity) // 2]) > 0.1


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"times": [0.2, 0.1], "positions": np.zeros((2, 7))}, "strictly increasing"),
        ({"times": [0.1], "positions": np.full((1, 7), np.nan)}, "finite"),
        ({"times": [0.1], "positions": np.zeros((1, 6))}, "positions"),
        ({"times": [0.1], "positions": Q_READY[None], "velocities": np.zeros((2, 7))}, "velocities"),
        ({"times": [0.1], "positions": Q_READY[None], "stamp": 1.0, "now": 5.0}, "ended"),
        # beyond the arm's limits: values like these made MuJoCo reset the simulation ("Nan, Inf or huge value")
        ({"times": [0.5], "positions": (Q_READY + [5.0, 0, 0, 0, 0, 0, 0])[None]}, "position of panda_joint1"),
        ({"times": [0.1, 0.2], "positions": [Q_READY, Q_READY + 1.0]}, "mean velocity"),
        ({"times": [0.5], "positions": Q_READY[None], "velocities": np.full((1, 7), 1e300)}, "velocity of"),
        (
            {
                "times": [0.5],
                "positions": Q_READY[None],
                "velocities": np.zeros((1, 7)),
                "accelerations": np.full((1, 7), 50.0),
            },
            "acceleration of",
        ),
        (
            {"times": [0.1, 1e6], "positions": [Q_READY, Q_READY], "velocities": np.ones((2, 7))},
            "interpolated position",
        ),
    ],
)
def test_bad_trajectories_are_refused_and_the_current_one_continues(kwargs, match):
    f = TrajectoryFollower(Q_READY)
    assert match in f.set_trajectory(**kwargs)
    np.testing.assert_array_equal(f.sample(6.0)[0], Q_READY)


def test_a_trajectory_within_the_limits_is_accepted_at_the_limits_themselves():
    f = TrajectoryFollower(Q_READY)
    t = np.array([0.0, 1.0])
    q = np.stack([Q_READY, Q_READY])
    q[:, 0] = Q_MAX[0]  # a joint held at its limit
    v = np.zeros((2, 7))
    assert f.set_trajectory(t, q, v, np.zeros((2, 7))) == ""
    assert "beyond its limit" in limit_violation(t, q + 0.1, v)

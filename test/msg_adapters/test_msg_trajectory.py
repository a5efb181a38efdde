"""msg_adapters.trajectory: joint trajectories and end-effector paths, round trips and refusals."""

from __future__ import annotations

import numpy as np
import pytest
from builtin_interfaces.msg import Duration, Time
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

from latent_planner_ros.robot.limits import JOINT_NAMES, Q_MAX, Q_MIN
from msg_adapters import (
    AdapterError,
    ee_path_to_path,
    joint_path_to_trajectory,
    path_to_arrays,
    trajectory_to_arrays,
)


def test_joint_trajectory_round_trip_random(rng):
    """120 random paths of 0..30 points, with repeated times and optional velocities."""
    for _ in range(120):
        t_len = int(rng.integers(0, 31))
        q = rng.uniform(Q_MIN, Q_MAX, size=(t_len, 7))
        times = np.cumsum(rng.choice([0.0, 0.01, 0.1, 0.37], size=t_len)) + rng.uniform(0, 2)
        dq = rng.normal(size=(t_len, 7)) if rng.random() < 0.5 else None
        msg = joint_path_to_trajectory(q, times, stamp=Time(sec=9, nanosec=1), velocities=dq)
        assert list(msg.joint_names) == list(JOINT_NAMES) and msg.header.stamp == Time(sec=9, nanosec=1)
        assert len(msg.points) == t_len
        q_out, t_out = trajectory_to_arrays(msg)
        assert q_out.shape == (t_len, 7) and t_out.shape == (t_len,)
        np.testing.assert_array_equal(q_out, q)
        np.testing.assert_allclose(t_out, times, atol=1e-9, rtol=0)
        for i, point in enumerate(msg.points):
            assert 0 <= point.time_from_start.nanosec < 1_000_000_000
            if dq is None:
                assert len(point.velocities) == 0
            else:
                np.testing.assert_array_equal(point.velocities, dq[i])


def test_time_from_start_split_into_sec_and_nanosec():
    msg = joint_path_to_trajectory(np.zeros((3, 7)), [0.0, 1.5, 2.000000001])
    assert [p.time_from_start for p in msg.points] == [
        Duration(sec=0, nanosec=0),
        Duration(sec=1, nanosec=500_000_000),
        Duration(sec=2, nanosec=1),
    ]


def test_trajectory_to_arrays_reorders_columns(rng):
    names = list(JOINT_NAMES)[::-1] + ["panda_finger_joint1"]
    msg = JointTrajectory(joint_names=names)
    q = rng.normal(size=(4, 7))
    msg.points = [
        JointTrajectoryPoint(positions=[*q[i, ::-1], 0.04], time_from_start=Duration(sec=i)) for i in range(4)
    ]
    q_out, t_out = trajectory_to_arrays(msg)
    np.testing.assert_array_equal(q_out, q)
    np.testing.assert_array_equal(t_out, np.arange(4.0))


def test_trajectory_to_arrays_refuses():
    msg = JointTrajectory(joint_names=list(JOINT_NAMES[:6]))
    with pytest.raises(AdapterError, match=r"lacks joints \['panda_joint7'\]"):
        trajectory_to_arrays(msg)
    msg = JointTrajectory(joint_names=list(JOINT_NAMES) + ["panda_joint1"])
    with pytest.raises(AdapterError, match="duplicates"):
        trajectory_to_arrays(msg)
    msg = JointTrajectory(joint_names=list(JOINT_NAMES), points=[JointTrajectoryPoint(positions=[0.0] * 6)])
    with pytest.raises(AdapterError, match="point 0 has 6 positions for 7 joints"):
        trajectory_to_arrays(msg)


@pytest.mark.parametrize(
    ("q", "t", "kwargs", "match"),
    [
        (np.zeros((3, 6)), np.zeros(3), {}, r"q_path: expected shape \(N, 7\)"),
        (np.zeros(7), np.zeros(1), {}, r"q_path: expected shape \(N, 7\)"),
        (np.zeros((3, 7)), np.zeros(2), {}, r"times_s: expected shape \(3\)"),
        (np.full((3, 7), np.nan), np.zeros(3), {}, "q_path: contains NaN"),
        (np.zeros((3, 7)), [0.0, np.inf, 1.0], {}, "times_s: contains NaN or inf"),
        (np.zeros((3, 7)), [0.0, 1.0, 0.5], {}, r"nondecreasing: t\[1\] = 1.0 > t\[2\] = 0.5"),
        (np.zeros((3, 7)), [-0.1, 0.0, 1.0], {}, ">= 0"),
        (np.zeros((3, 7)), np.zeros(3), {"velocities": np.zeros((2, 7))}, r"velocities: expected shape \(3, 7\)"),
        (np.zeros((3, 7)), np.zeros(3), {"velocities": np.full((3, 7), np.nan)}, "velocities: contains NaN"),
        (np.zeros((3, 2)), np.zeros(3), {"names": ["a", "a"]}, "unique"),
    ],
)
def test_joint_path_to_trajectory_refuses(q, t, kwargs, match):
    with pytest.raises(AdapterError, match=match):
        joint_path_to_trajectory(q, t, **kwargs)


def test_ee_path_round_trip_random(rng):
    """120 random paths of 0..30 poses; every pose carries the path's stamp and frame."""
    for _ in range(120):
        t_len = int(rng.integers(0, 31))
        pos = rng.uniform(-1, 1, size=(t_len, 3))
        quat = rng.normal(size=(t_len, 4)) * rng.uniform(0.1, 5.0, size=(t_len, 1))
        stamp = Time(sec=int(rng.integers(0, 1000)), nanosec=int(rng.integers(0, 10**9)))
        msg = ee_path_to_path(pos, quat, frame_id="world", stamp=stamp)
        assert msg.header.frame_id == "world" and msg.header.stamp == stamp
        assert all(p.header.frame_id == "world" and p.header.stamp == stamp for p in msg.poses)
        pos_out, quat_out = path_to_arrays(msg)
        assert pos_out.shape == (t_len, 3) and quat_out.shape == (t_len, 4)
        np.testing.assert_array_equal(pos_out, pos)
        np.testing.assert_allclose(quat_out, quat / np.linalg.norm(quat, axis=1, keepdims=True), atol=1e-12)


@pytest.mark.parametrize(
    ("pos", "quat", "match"),
    [
        (np.zeros((2, 2)), np.zeros((2, 4)), r"positions: expected shape \(N, 3\)"),
        (np.zeros((2, 3)), np.ones((3, 4)), r"quaternions_xyzw: expected shape \(2, 4\)"),
        (np.zeros((2, 3)), np.ones((2, 3)), r"quaternions_xyzw: expected shape \(2, 4\)"),
        (np.full((2, 3), np.nan), np.ones((2, 4)), "positions: contains NaN"),
        (np.zeros((2, 3)), [[0, 0, 0, 1], [0, 0, np.nan, 1]], "quaternions_xyzw: contains NaN"),
        (np.zeros((2, 3)), [[0, 0, 0, 1], [0, 0, 0, 0]], r"quaternions_xyzw\[1\] has zero norm"),
    ],
)
def test_ee_path_to_path_refuses(pos, quat, match):
    with pytest.raises(AdapterError, match=match):
        ee_path_to_path(pos, quat)

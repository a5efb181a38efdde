"""msg_adapters.joint_state: name-based reordering, round trips and refusals."""

from __future__ import annotations

import numpy as np
import pytest
from builtin_interfaces.msg import Time
from sensor_msgs.msg import JointState

from latent_planner_ros.robot.limits import JOINT_NAMES, Q_MAX, Q_MIN, Q_READY
from msg_adapters import AdapterError, joint_state_to_q, q_to_joint_state

FINGERS = ("panda_finger_joint1", "panda_finger_joint2")


def _msg(names, position, velocity=()) -> JointState:
    msg = JointState()
    msg.name = list(names)
    msg.position = [float(v) for v in position]
    msg.velocity = [float(v) for v in velocity]
    return msg


def test_round_trip_ready_pose():
    msg = q_to_joint_state(Q_READY, stamp=Time(sec=3, nanosec=7))
    assert list(msg.name) == list(JOINT_NAMES)
    assert msg.header.stamp == Time(sec=3, nanosec=7)
    assert len(msg.velocity) == 0 and len(msg.effort) == 0
    q, dq = joint_state_to_q(msg)
    np.testing.assert_array_equal(q, Q_READY)
    assert q.dtype == np.float64 and q.shape == (7,)
    assert dq is None


def test_random_order_and_extra_joints(rng):
    """150 random messages: joints shuffled among finger joints, with or without velocities."""
    for _ in range(150):
        q = rng.uniform(Q_MIN, Q_MAX)
        dq = rng.normal(size=7) if rng.random() < 0.5 else None
        extra = list(FINGERS[: rng.integers(0, 3)])
        names = list(JOINT_NAMES) + extra
        values = list(q) + [0.04] * len(extra)
        vels = None if dq is None else list(dq) + [0.0] * len(extra)
        order = rng.permutation(len(names))
        msg = _msg(
            [names[i] for i in order],
            [values[i] for i in order],
            () if vels is None else [vels[i] for i in order],
        )
        q_out, dq_out = joint_state_to_q(msg)
        np.testing.assert_array_equal(q_out, q)
        if dq is None:
            assert dq_out is None
        else:
            np.testing.assert_array_equal(dq_out, dq)


def test_q_to_joint_state_with_velocities_and_custom_names(rng):
    q, dq = rng.normal(size=2), rng.normal(size=2)
    msg = q_to_joint_state(q, dq, names=FINGERS)
    assert list(msg.name) == list(FINGERS)
    q_out, dq_out = joint_state_to_q(msg, names=FINGERS[::-1])
    np.testing.assert_array_equal(q_out, q[::-1])
    np.testing.assert_array_equal(dq_out, dq[::-1])


def test_non_finite_extra_joint_is_ignored():
    msg = _msg(list(JOINT_NAMES) + ["panda_finger_joint1"], list(Q_READY) + [float("nan")])
    q, _ = joint_state_to_q(msg)
    np.testing.assert_array_equal(q, Q_READY)


def test_missing_joints_are_named():
    names = [n for n in JOINT_NAMES if n not in ("panda_joint3", "panda_joint6")]
    with pytest.raises(AdapterError, match=r"panda_joint3.*panda_joint6"):
        joint_state_to_q(_msg(names, np.zeros(5)))


def test_position_length_mismatch():
    with pytest.raises(AdapterError, match="7 names but 6 positions"):
        joint_state_to_q(_msg(JOINT_NAMES, np.zeros(6)))


@pytest.mark.parametrize("n_vel", [1, 6, 8])
def test_velocity_length_mismatch(n_vel):
    with pytest.raises(AdapterError, match=f"{n_vel} velocities"):
        joint_state_to_q(_msg(JOINT_NAMES, np.zeros(7), np.zeros(n_vel)))


@pytest.mark.parametrize("bad", [float("nan"), float("inf"), -float("inf")])
def test_non_finite_position(bad):
    q = Q_READY.copy()
    q[4] = bad
    with pytest.raises(AdapterError, match="position.*panda_joint5"):
        joint_state_to_q(_msg(JOINT_NAMES, q))


def test_non_finite_velocity():
    dq = np.zeros(7)
    dq[0] = np.nan
    with pytest.raises(AdapterError, match="velocity.*panda_joint1"):
        joint_state_to_q(_msg(JOINT_NAMES, Q_READY, dq))


def test_duplicate_names():
    names = list(JOINT_NAMES) + ["panda_joint2"]
    with pytest.raises(AdapterError, match="more than once.*panda_joint2"):
        joint_state_to_q(_msg(names, np.zeros(8)))


@pytest.mark.parametrize(
    ("q", "dq", "match"),
    [
        (np.zeros(6), None, r"q: expected shape \(7\)"),
        (np.zeros((1, 7)), None, r"q: expected shape \(7\)"),
        (np.full(7, np.nan), None, "q: contains NaN"),
        (np.zeros(7), np.zeros(3), r"dq: expected shape \(7\)"),
        (np.zeros(7), np.full(7, np.inf), "dq: contains NaN or inf"),
    ],
)
def test_q_to_joint_state_refuses(q, dq, match):
    with pytest.raises(AdapterError, match=match):
        q_to_joint_state(q, dq)


def test_q_to_joint_state_refuses_duplicate_names():
    with pytest.raises(AdapterError, match="unique"):
        q_to_joint_state(np.zeros(2), names=["a", "a"])

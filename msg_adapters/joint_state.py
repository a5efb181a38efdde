"""sensor_msgs/JointState <-> joint vectors q [rad] and dq [rad/s], reordered by joint name."""

from __future__ import annotations

from collections import Counter
from collections.abc import Sequence

import numpy as np
from builtin_interfaces.msg import Time
from sensor_msgs.msg import JointState

from latent_planner_ros.robot.limits import JOINT_NAMES
from msg_adapters._common import as_float_array, stamp_or_zero
from msg_adapters.errors import AdapterError


def joint_state_to_q(msg: JointState, names: Sequence[str] = JOINT_NAMES) -> tuple[np.ndarray, np.ndarray | None]:
    """Joint positions (and velocities) of `names`, in the order of `names`.

    Args:
        msg: a JointState; it may list its joints in any order and carry extra joints (e.g. fingers),
            which are ignored.
        names: the joints to extract, default the Panda arm joints panda_joint1..7.

    Returns:
        q: shape (len(names),) float64 [rad].
        dq: shape (len(names),) float64 [rad/s], or None if the message has no velocities.

    Raises:
        AdapterError: duplicate joint names, len(position) != len(name), len(velocity) not in
            {0, len(name)}, a requested joint missing (all missing ones are named), or a NaN/inf
            position or velocity of a requested joint.
    """
    msg_names = list(msg.name)
    duplicates = sorted(n for n, c in Counter(msg_names).items() if c > 1)
    if duplicates:
        raise AdapterError(f"JointState.name lists joints more than once: {duplicates}")
    if len(msg.position) != len(msg_names):
        raise AdapterError(f"JointState has {len(msg_names)} names but {len(msg.position)} positions")
    if len(msg.velocity) not in (0, len(msg_names)):
        raise AdapterError(
            f"JointState has {len(msg_names)} names but {len(msg.velocity)} velocities (expected 0 or {len(msg_names)})"
        )
    index = {n: i for i, n in enumerate(msg_names)}
    missing = [n for n in names if n not in index]
    if missing:
        raise AdapterError(f"JointState lacks joints {missing} (has {msg_names})")
    rows = np.array([index[n] for n in names], dtype=np.intp)

    q = np.asarray(msg.position, dtype=np.float64)[rows]
    bad = [n for n, ok in zip(names, np.isfinite(q), strict=True) if not ok]
    if bad:
        raise AdapterError(f"JointState position is NaN or inf for joints {bad}")
    if len(msg.velocity) == 0:
        return q, None
    dq = np.asarray(msg.velocity, dtype=np.float64)[rows]
    bad = [n for n, ok in zip(names, np.isfinite(dq), strict=True) if not ok]
    if bad:
        raise AdapterError(f"JointState velocity is NaN or inf for joints {bad}")
    return q, dq


def q_to_joint_state(
    q: np.ndarray,
    dq: np.ndarray | None = None,
    names: Sequence[str] = JOINT_NAMES,
    stamp: Time | None = None,
) -> JointState:
    """A JointState with positions q [rad] (shape (len(names),)) and optional velocities dq [rad/s].

    The header stamp is `stamp` (builtin_interfaces/Time; zero when None); the frame_id is left empty
    (joint states have no frame). Efforts are left empty.

    Raises:
        AdapterError: wrong shape, NaN/inf values, or duplicate names.
    """
    names = list(names)
    if len(set(names)) != len(names):
        raise AdapterError(f"joint names must be unique, got {names}")
    q = as_float_array(q, (len(names),), "q")
    msg = JointState()
    msg.header.stamp = stamp_or_zero(stamp)
    msg.name = names
    msg.position = q.tolist()
    if dq is not None:
        msg.velocity = as_float_array(dq, (len(names),), "dq").tolist()
    return msg

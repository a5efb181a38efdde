"""Plans as messages: joint paths <-> trajectory_msgs/JointTrajectory, end-effector paths <-> nav_msgs/Path."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from builtin_interfaces.msg import Time
from geometry_msgs.msg import PoseStamped
from nav_msgs.msg import Path
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

from latent_planner_ros.robot.limits import JOINT_NAMES
from msg_adapters._common import as_float_array, duration_to_seconds, seconds_to_duration, stamp_or_zero
from msg_adapters.errors import AdapterError

_MIN_QUAT_NORM = 1e-9


def joint_path_to_trajectory(
    q_path: np.ndarray,
    times_s: np.ndarray,
    names: Sequence[str] = JOINT_NAMES,
    stamp: Time | None = None,
    velocities: np.ndarray | None = None,
    accelerations: np.ndarray | None = None,
) -> JointTrajectory:
    """A JointTrajectory with one point per row of q_path.

    Args:
        q_path: shape (T, J) joint positions [rad], J = len(names); T may be 0 (empty trajectory).
        times_s: shape (T,) time from start [s] of each point, finite, >= 0 and nondecreasing.
        names: joint names, default panda_joint1..7.
        stamp: header stamp (builtin_interfaces/Time; zero when None). The frame_id is left empty.
        velocities: optional shape (T, J) joint velocities [rad/s].
        accelerations: optional shape (T, J) joint accelerations [rad/s^2] (with velocities, as a
            JointTrajectoryController expects for its quintic interpolation).

    Raises:
        AdapterError: wrong shapes, NaN/inf values, negative or decreasing times, duplicate names.
    """
    names = list(names)
    if len(set(names)) != len(names):
        raise AdapterError(f"joint names must be unique, got {names}")
    q = as_float_array(q_path, (None, len(names)), "q_path")
    t = as_float_array(times_s, (q.shape[0],), "times_s")
    if t.size and t[0] < 0:
        raise AdapterError(f"times_s must be >= 0, got {t[0]}")
    if np.any(np.diff(t) < 0):
        i = int(np.argmax(np.diff(t) < 0))
        raise AdapterError(f"times_s must be nondecreasing: t[{i}] = {t[i]} > t[{i + 1}] = {t[i + 1]}")
    dq = None if velocities is None else as_float_array(velocities, q.shape, "velocities")
    ddq = None if accelerations is None else as_float_array(accelerations, q.shape, "accelerations")

    msg = JointTrajectory()
    msg.header.stamp = stamp_or_zero(stamp)
    msg.joint_names = names
    points = []
    for i in range(q.shape[0]):
        point = JointTrajectoryPoint(positions=q[i].tolist(), time_from_start=seconds_to_duration(t[i]))
        if dq is not None:
            point.velocities = dq[i].tolist()
        if ddq is not None:
            point.accelerations = ddq[i].tolist()
        points.append(point)
    msg.points = points
    return msg


def trajectory_to_arrays(msg: JointTrajectory, names: Sequence[str] = JOINT_NAMES) -> tuple[np.ndarray, np.ndarray]:
    """Positions and times of a JointTrajectory, columns reordered to `names`.

    Returns:
        q: shape (T, len(names)) float64 [rad].
        t: shape (T,) float64 time from start [s].

    Raises:
        AdapterError: missing or duplicate joints, or a point whose positions do not match joint_names.
    """
    msg_names = list(msg.joint_names)
    if len(set(msg_names)) != len(msg_names):
        raise AdapterError(f"JointTrajectory.joint_names has duplicates: {msg_names}")
    missing = [n for n in names if n not in msg_names]
    if missing:
        raise AdapterError(f"JointTrajectory lacks joints {missing} (has {msg_names})")
    cols = [msg_names.index(n) for n in names]
    q = np.empty((len(msg.points), len(names)), dtype=np.float64)
    t = np.empty(len(msg.points), dtype=np.float64)
    for i, point in enumerate(msg.points):
        if len(point.positions) != len(msg_names):
            raise AdapterError(
                f"JointTrajectory point {i} has {len(point.positions)} positions for {len(msg_names)} joints"
            )
        q[i] = np.asarray(point.positions, dtype=np.float64)[cols]
        t[i] = duration_to_seconds(point.time_from_start)
    return q, t


def trajectory_to_execution(
    msg: JointTrajectory, names: Sequence[str] = JOINT_NAMES
) -> tuple[np.ndarray, np.ndarray, np.ndarray | None, np.ndarray | None]:
    """A JointTrajectory to execute, validated as a JointTrajectoryController would, columns reordered to `names`.

    Returns:
        times: (K,) time from start [s], >= 0 and strictly increasing, K >= 1.
        positions: (K, J) [rad]; velocities, accelerations: (K, J) [rad/s], [rad/s^2], or None when no point
            carries them.

    Raises:
        AdapterError: no points; joint names duplicated, missing or unknown; a point whose positions, velocities or
            accelerations do not match joint_names (velocities and accelerations: all points or none); NaN/inf;
            negative or non-increasing times.
    """
    msg_names = list(msg.joint_names)
    unknown = [n for n in msg_names if n not in names]
    if unknown:
        raise AdapterError(f"JointTrajectory has unknown joints {unknown} (expected {list(names)})")
    q, t = trajectory_to_arrays(msg, names)
    if len(t) == 0:
        raise AdapterError("JointTrajectory has no points")
    if not np.all(np.isfinite(q)) or not np.all(np.isfinite(t)):
        raise AdapterError("JointTrajectory has NaN or inf positions or times")
    if t[0] < 0 or np.any(np.diff(t) <= 0):
        raise AdapterError(f"JointTrajectory time_from_start must be >= 0 and strictly increasing, got {t.tolist()}")
    cols = [msg_names.index(n) for n in names]
    derivatives: list[np.ndarray | None] = []
    for field in ("velocities", "accelerations"):
        lengths = {len(getattr(p, field)) for p in msg.points}
        if lengths == {0}:
            derivatives.append(None)
            continue
        if lengths != {len(msg_names)}:
            raise AdapterError(f"JointTrajectory {field}: every point needs {len(msg_names)} values or none")
        values = np.array([np.asarray(getattr(p, field), dtype=np.float64)[cols] for p in msg.points])
        if not np.all(np.isfinite(values)):
            raise AdapterError(f"JointTrajectory {field} contain NaN or inf")
        derivatives.append(values)
    return t, q, derivatives[0], derivatives[1]


def ee_path_to_path(
    positions: np.ndarray,
    quaternions_xyzw: np.ndarray,
    frame_id: str = "world",
    stamp: Time | None = None,
) -> Path:
    """A nav_msgs/Path of end-effector poses; the path and every pose carry the same stamp and frame.

    Args:
        positions: shape (T, 3) [m] in frame_id; T may be 0 (an empty path, e.g. a failed plan).
        quaternions_xyzw: shape (T, 4), (x, y, z, w) order; normalised here.

    Raises:
        AdapterError: wrong shapes, NaN/inf values or a zero-norm quaternion.
    """
    pos = as_float_array(positions, (None, 3), "positions")
    quat = as_float_array(quaternions_xyzw, (pos.shape[0], 4), "quaternions_xyzw")
    norms = np.linalg.norm(quat, axis=1)
    if np.any(norms < _MIN_QUAT_NORM):
        raise AdapterError(f"quaternions_xyzw[{int(np.argmax(norms < _MIN_QUAT_NORM))}] has zero norm")
    quat = quat / norms[:, None]
    stamp = stamp_or_zero(stamp)

    msg = Path()
    msg.header.frame_id = frame_id
    msg.header.stamp = stamp
    poses = []
    for p, q in zip(pos, quat, strict=True):
        pose = PoseStamped()
        pose.header.frame_id = frame_id
        pose.header.stamp = stamp
        pose.pose.position.x, pose.pose.position.y, pose.pose.position.z = (float(v) for v in p)
        o = pose.pose.orientation
        o.x, o.y, o.z, o.w = (float(v) for v in q)
        poses.append(pose)
    msg.poses = poses
    return msg


def path_to_arrays(msg: Path) -> tuple[np.ndarray, np.ndarray]:
    """Positions (T, 3) [m] and quaternions (T, 4) (x, y, z, w, as stored) of a nav_msgs/Path."""
    pos = np.array([[p.pose.position.x, p.pose.position.y, p.pose.position.z] for p in msg.poses], dtype=np.float64)
    quat = np.array(
        [[p.pose.orientation.x, p.pose.orientation.y, p.pose.orientation.z, p.pose.orientation.w] for p in msg.poses],
        dtype=np.float64,
    )
    return pos.reshape(-1, 3), quat.reshape(-1, 4)

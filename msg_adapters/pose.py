"""geometry_msgs/PoseStamped <-> end-effector targets (position [m], unit quaternion, rotation, 6D)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from builtin_interfaces.msg import Time
from geometry_msgs.msg import PoseStamped

from msg_adapters._common import as_float_array, stamp_or_zero
from msg_adapters.errors import AdapterError

_MIN_QUAT_NORM = 1e-9


@dataclass(frozen=True, eq=False)
class PoseTarget:
    """An end-effector target pose. Arrays are read-only.

    position: shape (3,) float64 [m] in frame_id.
    quaternion_xyzw: shape (4,) float64, unit norm, (x, y, z, w) order (sign as given).
    rotation: shape (3, 3) float64 rotation matrix of the quaternion.
    rot6d: shape (6,) float64, the first two columns of `rotation` (r00, r10, r20, r01, r11, r21).
    frame_id: the frame the pose is expressed in (normally "world").
    """

    position: np.ndarray
    quaternion_xyzw: np.ndarray
    rotation: np.ndarray
    rot6d: np.ndarray
    frame_id: str


def _read_only(a: np.ndarray) -> np.ndarray:
    a = np.array(a, dtype=np.float64)
    a.setflags(write=False)
    return a


def _unit_quaternion(quat, what: str) -> np.ndarray:
    q = np.asarray(quat, dtype=np.float64)
    if q.shape != (4,):
        raise AdapterError(f"{what}: expected 4 components (x, y, z, w), got shape {q.shape}")
    if not np.all(np.isfinite(q)):
        raise AdapterError(f"{what} has NaN or inf components: {q.tolist()}")
    scale = float(np.max(np.abs(q)))  # huge components would overflow the norm (1e200 ** 2 = inf)
    unit = q / scale if scale > 0.0 else q
    norm = scale * float(np.linalg.norm(unit))
    if norm < _MIN_QUAT_NORM:
        raise AdapterError(f"{what} has zero norm")
    return unit / np.linalg.norm(unit)


def pose_stamped_to_target(msg: PoseStamped, expected_frame: str | None = "world") -> PoseTarget:
    """A PoseTarget from a PoseStamped; the orientation quaternion is normalised.

    An empty header.frame_id is taken to mean `expected_frame`. With expected_frame None any frame
    is accepted and reported in PoseTarget.frame_id.

    Raises:
        AdapterError: NaN/inf position or orientation, zero-norm quaternion, or a frame other than
            expected_frame.
    """
    frame = msg.header.frame_id
    if expected_frame is not None:
        if frame == "":
            frame = expected_frame
        elif frame != expected_frame:
            raise AdapterError(f"PoseStamped frame_id is {frame!r}, expected {expected_frame!r}")
    p, o = msg.pose.position, msg.pose.orientation
    position = np.array([p.x, p.y, p.z], dtype=np.float64)
    if not np.all(np.isfinite(position)):
        raise AdapterError(f"PoseStamped position has NaN or inf: {position.tolist()}")
    quat = _unit_quaternion([o.x, o.y, o.z, o.w], "PoseStamped orientation")
    # Imported here: rotations pulls in torch and scipy (~2 s), which nodes that never read poses skip.
    from latent_planner_ros.robot.rotations import matrix_to_rot6d_np, quat_to_matrix

    rotation = quat_to_matrix(quat)
    return PoseTarget(
        position=_read_only(position),
        quaternion_xyzw=_read_only(quat),
        rotation=_read_only(rotation),
        rot6d=_read_only(matrix_to_rot6d_np(rotation)),
        frame_id=frame,
    )


def target_to_pose_stamped(
    position: np.ndarray,
    quaternion_xyzw: np.ndarray,
    frame_id: str = "world",
    stamp: Time | None = None,
) -> PoseStamped:
    """A PoseStamped from position (3,) [m] and quaternion (4,) (x, y, z, w; normalised here).

    Raises:
        AdapterError: wrong shapes, NaN/inf values or a zero-norm quaternion.
    """
    pos = as_float_array(position, (3,), "position")
    quat = _unit_quaternion(quaternion_xyzw, "quaternion_xyzw")
    msg = PoseStamped()
    msg.header.frame_id = frame_id
    msg.header.stamp = stamp_or_zero(stamp)
    msg.pose.position.x, msg.pose.position.y, msg.pose.position.z = (float(v) for v in pos)
    o = msg.pose.orientation
    o.x, o.y, o.z, o.w = (float(v) for v in quat)
    return msg


def pose_stamped_in_base(msg: PoseStamped, frames) -> PoseTarget:
    """A PoseTarget in the robot base frame from a PoseStamped in any frame `frames` accepts.

    frames: a latent_planner_ros.perception.frames.Frames (`world` = empty frame_id, the base frame, the
    configured sensor frames). The returned target's frame_id is frames.base_frame.

    Raises:
        AdapterError: what pose_stamped_to_target refuses, or a frame without a transform (naming the accepted).
    """
    from latent_planner_ros.perception.frames import FrameRefused
    from latent_planner_ros.robot.rotations import matrix_to_quat, matrix_to_rot6d_np

    target = pose_stamped_to_target(msg, expected_frame=None)
    try:
        position, rotation = frames.pose_to_base(target.frame_id, target.position, target.rotation)
    except FrameRefused as err:
        raise AdapterError(f"PoseStamped {err}") from None
    return PoseTarget(
        position=_read_only(position),
        quaternion_xyzw=_read_only(matrix_to_quat(rotation)),
        rotation=_read_only(rotation),
        rot6d=_read_only(matrix_to_rot6d_np(rotation)),
        frame_id=frames.base_frame,
    )

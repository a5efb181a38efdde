"""The frames a node accepts goals and clouds in, and their static transforms into the robot base frame. No ROS.

Planning happens in the robot base frame (`panda_link0`, or `<prefix>link0`). A node accepts data in:
- the base frame itself (identity);
- `world`, in which the base stands at `base_offset` (default identity: the base at the origin);
- a configured sensor frame (a static extrinsic: the frame's pose in `world`).
Anything else is refused with one reason, the same for every node (:class:`FrameRefused`). An empty frame_id
is taken as `world`.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np

WORLD = "world"


class FrameRefused(ValueError):
    """Data in a frame the node has no transform for; the message names the frame and the accepted ones."""


def rpy_to_matrix(roll: float, pitch: float, yaw: float) -> np.ndarray:
    """(3, 3) rotation of URDF roll-pitch-yaw [rad] (fixed axes X, Y, Z: R = Rz(yaw) Ry(pitch) Rx(roll))."""
    cr, sr, cp, sp, cy, sy = np.cos(roll), np.sin(roll), np.cos(pitch), np.sin(pitch), np.cos(yaw), np.sin(yaw)
    return np.array(
        [
            [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
            [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
            [-sp, cp * sr, cp * cr],
        ]
    )


def quat_xyzw_to_matrix(q: Sequence[float]) -> np.ndarray:
    """(3, 3) rotation of a quaternion (x, y, z, w), normalised here (ValueError for a zero one)."""
    x, y, z, w = np.asarray(q, dtype=float)
    n = np.sqrt(x * x + y * y + z * z + w * w)
    if not n > 1e-9:
        raise ValueError("zero quaternion")
    x, y, z, w = x / n, y / n, z / n, w / n
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )


@dataclass(frozen=True)
class Transform:
    """A rigid transform p_parent = rotation @ p_child + translation (rotation (3, 3), translation (3,) [m])."""

    rotation: np.ndarray = field(default_factory=lambda: np.eye(3))
    translation: np.ndarray = field(default_factory=lambda: np.zeros(3))

    @classmethod
    def from_pose(cls, values: Sequence[float]) -> Transform:
        """From x y z [m] + roll pitch yaw [rad] (6 numbers) or x y z + quaternion x y z w (7 numbers).

        Raises:
            ValueError: another count, a non-finite number or a zero quaternion.
        """
        v = np.asarray(values, dtype=float).reshape(-1)
        if v.shape not in ((6,), (7,)) or not np.all(np.isfinite(v)):
            raise ValueError(f"expected x y z roll pitch yaw (6 finite numbers) or x y z qx qy qz qw (7), got {v}")
        rotation = rpy_to_matrix(*v[3:]) if len(v) == 6 else quat_xyzw_to_matrix(v[3:].tolist())
        return cls(rotation, v[:3].copy())

    @property
    def is_identity(self) -> bool:
        return bool(np.allclose(self.rotation, np.eye(3)) and np.allclose(self.translation, 0.0))

    def inverse(self) -> Transform:
        r = self.rotation.T
        return Transform(r, -r @ self.translation)

    def __matmul__(self, other: Transform) -> Transform:
        """self after other: (A @ B)(p) = A(B(p))."""
        return Transform(self.rotation @ other.rotation, self.rotation @ other.translation + self.translation)

    def points(self, p: np.ndarray) -> np.ndarray:
        """Points (N, 3) moved by this transform, keeping their dtype."""
        p = np.asarray(p)
        if self.is_identity:
            return p
        out = p.astype(np.float64) @ self.rotation.T + self.translation
        return out.astype(p.dtype if np.issubdtype(p.dtype, np.floating) else np.float64, copy=False)


@dataclass(frozen=True)
class Frames:
    """The accepted frames of a node.

    Attributes:
        base_frame: the robot base frame (planning frame), e.g. `panda_link0`.
        base_in_world: the base's pose in `world` (identity: the base at the origin).
        extrinsics: {sensor frame: its pose in `world`}.
    """

    base_frame: str = "panda_link0"
    base_in_world: Transform = field(default_factory=Transform)
    extrinsics: Mapping[str, Transform] = field(default_factory=dict)

    @property
    def accepted(self) -> tuple[str, ...]:
        return tuple(dict.fromkeys((WORLD, self.base_frame, *self.extrinsics)))

    def to_base(self, frame_id: str) -> Transform:
        """The transform taking coordinates in `frame_id` into the base frame ("" = world).

        Raises:
            FrameRefused: an unknown frame, naming the accepted ones.
        """
        frame = frame_id or WORLD
        if frame == self.base_frame:
            return Transform()
        world_to_base = self.base_in_world.inverse()
        if frame == WORLD:
            return world_to_base
        if frame in self.extrinsics:
            return world_to_base @ self.extrinsics[frame]
        raise FrameRefused(
            f"frame {frame!r} has no transform to {self.base_frame!r} (accepted: {', '.join(self.accepted)}; "
            "add a static extrinsic in frames.extrinsics)"
        )

    def points_to_base(self, frame_id: str, points: np.ndarray) -> np.ndarray:
        """Points (N, 3) [m] given in frame_id, in the base frame (FrameRefused for an unknown frame)."""
        return self.to_base(frame_id).points(points)

    def pose_to_base(self, frame_id: str, position: np.ndarray, rotation: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(position (3,) [m], rotation (3, 3)) of a pose given in frame_id, in the base frame."""
        t = self.to_base(frame_id)
        return t.rotation @ np.asarray(position, dtype=float) + t.translation, t.rotation @ np.asarray(rotation)

    def base_to_world(self, points: np.ndarray) -> np.ndarray:
        """Points (N, 3) [m] in the base frame, in `world` (for outputs stamped `world`)."""
        return self.base_in_world.points(points)


def parse_extrinsics(text: str) -> dict[str, Transform]:
    """{frame: pose in world} of "frame: x y z roll pitch yaw; other: x y z qx qy qz qw" ("" = none).

    Raises:
        ValueError: a malformed entry, a frame named twice, or `world` given an extrinsic.
    """
    out: dict[str, Transform] = {}
    for entry in filter(None, (e.strip() for e in text.split(";"))):
        frame, sep, numbers = entry.partition(":")
        frame = frame.strip()
        if not sep or not frame or " " in frame:
            raise ValueError(f"{entry!r}: expected 'frame: x y z roll pitch yaw' or 'frame: x y z qx qy qz qw'")
        if frame == WORLD or frame in out:
            raise ValueError(f"{entry!r}: frame {frame!r} is {'world' if frame == WORLD else 'given twice'}")
        try:
            out[frame] = Transform.from_pose([float(v) for v in numbers.split()])
        except ValueError as err:
            raise ValueError(f"{entry!r}: {err}") from None
    return out


def path_to_world(frames: Frames, positions: np.ndarray, quaternions: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A path in the base frame, positions (T, 3) [m] and quaternions (T, 4) (x, y, z, w), in `world`."""
    t = frames.base_in_world
    if t.is_identity:
        return positions, quaternions
    from scipy.spatial.transform import Rotation  # only for a robot not at the origin

    positions = t.points(np.asarray(positions, dtype=float).reshape(-1, 3))
    rotations = Rotation.from_matrix(t.rotation) * Rotation.from_quat(np.asarray(quaternions).reshape(-1, 4))
    return positions, rotations.as_quat()

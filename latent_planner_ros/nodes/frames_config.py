"""Frames and joint names of the robot, shared by every node's config (parameters `frames.*`)."""

from __future__ import annotations

from dataclasses import dataclass

from latent_planner_ros.params.config import ConfigError
from latent_planner_ros.perception.frames import Frames, Transform, parse_extrinsics

FRAMES_READ_ONLY = ("frames.joint_prefix", "frames.base_offset", "frames.extrinsics")
"""The frames are fixed at start-up: subscriptions, held goals and the robot description depend on them."""


@dataclass
class FramesConfig:
    joint_prefix: str = "panda_"
    """prefix of the arm's joint names (`<prefix>joint1` .. `<prefix>joint7`, read from joint_states and written in
    commands and trajectories) and of its base frame `<prefix>link0`; e.g. `fr3_` for a Franka Research 3"""
    base_offset: tuple[float, ...] = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    """pose of the robot base `<prefix>link0` in `world`: x y z [m] roll pitch yaw [rad] (URDF rpy), or x y z [m]
    and a quaternion qx qy qz qw; goals and clouds in `world` are moved into the base frame, where planning
    happens; the default puts the base at the origin"""
    extrinsics: str = ""
    """static poses in `world` of sensor frames whose clouds (and goals) are accepted: "frame: x y z roll pitch
    yaw; other: x y z qx qy qz qw" [m, rad]; data in a frame that is neither `world`, the base frame nor listed
    here is refused"""

    def __post_init__(self) -> None:
        p = self.joint_prefix
        if not (isinstance(p, str) and all(c.isalnum() or c in "_/" for c in p)):
            raise ConfigError(f"joint_prefix: expected a name prefix (letters, digits, _ or /), got {p!r}")
        try:
            Transform.from_pose(self.base_offset)
        except (ValueError, TypeError) as err:
            raise ConfigError(f"base_offset: {err}") from None
        if not isinstance(self.extrinsics, str):
            raise ConfigError(f"extrinsics: expected a string, got {self.extrinsics!r}")
        try:
            extrinsics = parse_extrinsics(self.extrinsics)
        except ValueError as err:
            raise ConfigError(f"extrinsics: {err}") from None
        if self.base_frame in extrinsics:
            raise ConfigError(f"extrinsics: {self.base_frame!r} is the base frame (set base_offset instead)")

    @property
    def joint_names(self) -> tuple[str, ...]:
        """The 7 arm joint names, `<prefix>joint1` .. `<prefix>joint7`."""
        return tuple(f"{self.joint_prefix}joint{i}" for i in range(1, 8))

    @property
    def base_frame(self) -> str:
        return f"{self.joint_prefix}link0"

    def frames(self) -> Frames:
        """The accepted frames and their transforms into the base frame."""
        return Frames(self.base_frame, Transform.from_pose(self.base_offset), parse_extrinsics(self.extrinsics))

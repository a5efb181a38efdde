"""CameraConfig: the simulated depth camera's intrinsics, pose and point-cloud processing.

Fields map 1:1 onto the ``camera.*`` parameters of the ``sim`` node and ``config/sim.yaml`` (and onto the
``<name>.*`` parameters of every other camera listed in ``cameras``; sim_bridge/camera_rig.py). Its intrinsics and
pose are the project's one camera description (latent_planner_ros/data/camera.py, optical frame).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from latent_planner_ros.data.camera import CameraIntrinsics
from latent_planner_ros.data.camera import look_at as look_at_pose
from latent_planner_ros.data.cloud_ops import REACH_CROP_MAX, REACH_CROP_MIN
from latent_planner_ros.params.config import ConfigError, check_int, check_number, check_vector
from sim_bridge.camera_frame import mujoco_from_optical

Vec3 = tuple[float, float, float]


@dataclass(frozen=True)
class CameraConfig:
    """A pinhole depth camera looking at the table, and how its depth image becomes a cloud.

    Intrinsics (:attr:`intrinsics`): square pixels, principal point at the image centre, focal length
    f = height / (2 tan(fovy / 2)) pixels. Pose (:meth:`pose`): the optical frame of data/camera.py.

    Attributes:
        width, height: [pixels] depth image size.
        fovy: [deg] vertical field of view.
        position: [m] (3,) optical centre in world.
        look_at: [m] (3,) the point the optical axis goes through (the image's up is world +z).
        min_depth, max_depth: [m] depth range; pixels outside are dropped.
        stride: keep every stride-th pixel row and column (decimation before unprojection).
        crop_min, crop_max: [m] (3,) axis-aligned box in world; points outside are dropped. By default it covers
            the arm's reach all around its base (|x|, |y| <= 1 m) and 1.3 m up (the Panda reaches about 1.19 m
            above its base), so nothing the arm can hit is cropped away.
        voxel_size: [m] voxel-grid downsampling (one point per occupied voxel, the mean); 0 = off.
        depth_noise: [m] standard deviation of Gaussian depth noise at 1 m depth (scales with depth^2,
            like a stereo camera); 0 = exact depth.
        dropout: fraction in [0, 1) of pixels dropped at random (missing depth).
        remove_robot: drop pixels that see the robot (segmentation by geom), as the planner expects.
        rate: [Hz] of this camera's cloud in simulated time; 0 = the sim's cloud_rate.
    """

    width: int = 320
    height: int = 240
    fovy: float = 45.0
    position: Vec3 = (1.6, 0.7, 0.9)
    look_at: Vec3 = (0.5, 0.0, 0.2)
    min_depth: float = 0.1
    max_depth: float = 3.0
    stride: int = 1
    crop_min: Vec3 = REACH_CROP_MIN
    crop_max: Vec3 = REACH_CROP_MAX
    voxel_size: float = 0.02
    depth_noise: float = 0.0
    dropout: float = 0.0
    remove_robot: bool = True
    rate: float = 0.0

    def __post_init__(self) -> None:
        check_int("width", self.width, 8, 1280)
        check_int("height", self.height, 8, 960)
        check_number("fovy", self.fovy, 1.0, 170.0)
        check_vector("position", self.position, 3)
        check_vector("look_at", self.look_at, 3)
        axis = np.subtract(self.look_at, self.position)
        if np.linalg.norm(axis) < 1e-3:
            raise ConfigError("look_at: must differ from position")
        if np.linalg.norm(np.cross(axis / np.linalg.norm(axis), [0.0, 0.0, 1.0])) < 1e-3:
            raise ConfigError("look_at: the camera must not look straight up or down (image up is world +z)")
        check_number("min_depth", self.min_depth, 0.0, 10.0, open_low=True)
        check_number("max_depth", self.max_depth, self.min_depth, 50.0, open_low=True)
        check_int("stride", self.stride, 1, 64)
        check_vector("crop_min", self.crop_min, 3)
        check_vector("crop_max", self.crop_max, 3)
        if any(lo >= hi for lo, hi in zip(self.crop_min, self.crop_max, strict=True)):
            raise ConfigError(f"crop_max: must exceed crop_min on every axis, got {self.crop_min} .. {self.crop_max}")
        check_number("voxel_size", self.voxel_size, 0.0, 1.0)
        check_number("depth_noise", self.depth_noise, 0.0, 1.0)
        check_number("dropout", self.dropout, 0.0, 0.99)
        if not isinstance(self.remove_robot, bool):
            raise ConfigError(f"remove_robot: expected true or false, got {self.remove_robot!r}")
        check_number("rate", self.rate, 0.0, 100.0)

    @property
    def intrinsics(self) -> CameraIntrinsics:
        """The pinhole intrinsics of the depth image (data/camera.py)."""
        return CameraIntrinsics.from_fov(self.width, self.height, self.fovy)

    def pose(self) -> np.ndarray:
        """(4, 4) camera-to-world transform in the optical frame (z towards look_at, x right, y down)."""
        return look_at_pose(np.asarray(self.position, dtype=float), np.asarray(self.look_at, dtype=float))

    def rotation(self) -> np.ndarray:
        """Orientation (3, 3) in world of the MJCF camera this config places (MuJoCo's camera frame: columns =
        image right, image up, backward; sim_bridge/camera_frame.py)."""
        return mujoco_from_optical(self.pose()[:3, :3])

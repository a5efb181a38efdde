"""The one camera description of the project: pinhole intrinsics and a camera-to-world pose in the optical frame.

Convention (ROS's optical frame, REP 103 and sensor_msgs/CameraInfo): z forward along the optical axis, x right and
y down in the image. Pixel (u, v), u the column from the left and v the row from the top, integer at pixel centres,
sees the ray ((u - cx) / fx, (v - cy) / fy, 1) in the camera frame; the depth of a pixel is the z coordinate of its
hit point in that frame. Poses are (4, 4) camera-to-world transforms whose rotation columns are the optical x, y, z
axes in `world`. The collision data (data/render.py) and the simulated cameras (sim_bridge/camera.py) both use it;
the sim turns it into MuJoCo's camera frame in one place (sim_bridge/camera_frame.py).

Also here: random viewpoints around the table for the collision data (CameraConfig, sample_camera_pose).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np


@dataclass(frozen=True)
class CameraIntrinsics:
    """Pinhole intrinsics: image size [px], focal lengths [px], principal point [px]."""

    width: int = 192
    height: int = 144
    fx: float = 138.3
    fy: float = 138.3
    cx: float = 95.5
    cy: float = 71.5

    @classmethod
    def from_fov(cls, width: int, height: int, fovy_deg: float) -> CameraIntrinsics:
        """Square pixels, vertical field of view fovy_deg [deg], principal point at the image centre."""
        f = (height / 2) / math.tan(math.radians(fovy_deg) / 2)
        return cls(width, height, f, f, (width - 1) / 2, (height - 1) / 2)

    def ray_directions(self, stride: int = 1) -> np.ndarray:
        """(H', W', 3) ray directions in the camera frame with unit z component, of every stride-th pixel row and
        column (H' = ceil(H / stride)); a pixel at depth d [m] is at d * ray."""
        u, v = np.meshgrid(np.arange(0, self.width, stride), np.arange(0, self.height, stride))
        return np.stack([(u - self.cx) / self.fx, (v - self.cy) / self.fy, np.ones(u.shape)], -1)


def unproject(depth: np.ndarray, rays: np.ndarray, pose: np.ndarray) -> np.ndarray:
    """World points (N, 3) float64 [m] of the pixels of a depth image with finite depth, in row-major order.

    Args:
        depth: (H', W') [m] along the optical axis; NaN or inf = no return.
        rays: (H', W', 3) from CameraIntrinsics.ray_directions (same decimation as depth).
        pose: (4, 4) camera-to-world transform (optical frame).
    """
    keep = np.isfinite(depth)
    return rays[keep] * depth[keep][:, None] @ pose[:3, :3].T + pose[:3, 3]


def look_at(eye: np.ndarray, target: np.ndarray) -> np.ndarray:
    """(4, 4) camera-to-world pose (optical frame) of a camera at `eye` (3,) [m] looking at `target` (3,) [m]: z along
    the line of sight, x horizontal (to the image's right), y down, so world up is up in the image. Looking straight
    down or up, x is world -y."""
    z = np.asarray(target, dtype=float) - np.asarray(eye, dtype=float)
    z /= np.linalg.norm(z)
    x = np.cross(z, [0.0, 0.0, 1.0])
    if np.linalg.norm(x) < 1e-6:  # looking straight down or up
        x = np.array([0.0, -1.0, 0.0])
    x /= np.linalg.norm(x)
    pose = np.eye(4)
    pose[:3, :3] = np.stack([x, np.cross(z, x), z], 1)
    pose[:3, 3] = eye
    return pose


@dataclass(frozen=True)
class CameraConfig:
    """The virtual depth camera of the collision data: intrinsics, viewpoint ranges, noise and crop."""

    intrinsics: CameraIntrinsics = field(default_factory=CameraIntrinsics)
    target: tuple[float, float, float] = (0.5, 0.0, 0.1)
    """point [m] the camera looks at (workspace centre)"""
    target_jitter: float = 0.1
    """uniform jitter [m] of the look-at point along each axis"""
    azimuth_deg: tuple[float, float] = (-180.0, 180.0)
    """range of the camera's azimuth [deg] around the target, 0 = on the +x side"""
    elevation_deg: tuple[float, float] = (20.0, 70.0)
    """range of the camera's elevation [deg] above the table plane, seen from the target"""
    distance: tuple[float, float] = (1.0, 1.8)
    """range of the camera's distance [m] from the target"""
    depth_noise: float = 0.002
    """standard deviation [m] of additive Gaussian depth noise"""
    depth_noise_quadratic: float = 0.0015
    """extra noise standard deviation per squared metre of depth [1/m] (structured-light style)"""
    max_depth: float = 4.0
    """rays that hit nothing within this depth [m] give no point"""
    crop_min: tuple[float, float, float] = (0.0, -0.6, -0.05)
    """lower corner [m] of the workspace box the cloud is cropped to (`world`): by default a new collision
    network's box (training crops to its network's box; clouds for planners use `planning_crop`)"""
    crop_max: tuple[float, float, float] = (1.0, 0.6, 0.55)
    """upper corner [m] of the crop box"""


def planning_crop() -> tuple[tuple[float, float, float], tuple[float, float, float]]:
    """Lower and upper corner [m] in `world` of the box the benches crop the clouds they give the planners to: the
    reach box of data/cloud_ops.py (the sim cameras' default `crop_min` / `crop_max` too), which covers the arm's
    reach all around its base, so no obstacle the arm can hit is cropped away. The collision network crops its own
    input to its smaller workspace box (its checkpoint's `grid`); the planners' geometric checks see the whole
    cloud."""
    from latent_planner_ros.data.cloud_ops import REACH_CROP_MAX, REACH_CROP_MIN

    return REACH_CROP_MIN, REACH_CROP_MAX


def sample_camera_pose(rng: np.random.Generator, config: CameraConfig) -> np.ndarray:
    """A random (4, 4) camera-to-world pose within the config's ranges, looking at the (jittered) target."""
    az = math.radians(rng.uniform(*config.azimuth_deg))
    el = math.radians(rng.uniform(*config.elevation_deg))
    dist = rng.uniform(*config.distance)
    target = np.asarray(config.target) + rng.uniform(-config.target_jitter, config.target_jitter, 3)
    eye = target + dist * np.array([math.cos(el) * math.cos(az), math.cos(el) * math.sin(az), math.sin(el)])
    return look_at(eye, target)

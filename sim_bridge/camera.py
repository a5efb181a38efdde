"""The simulated depth camera: OpenGL depth + geom segmentation -> point cloud in world, robot removed.

Each capture renders the scene offscreen once (depth and geom id per pixel), drops the pixels that see
the robot (or nothing), adds optional noise and dropout, unprojects into world, crops and downsamples. Rays and
poses are those of data/camera.py (optical frame); the MuJoCo camera's orientation is read through
sim_bridge/camera_frame.py.
"""

from __future__ import annotations

import mujoco
import numpy as np

from latent_planner_ros.data.camera import unproject
from sim_bridge.camera_config import CameraConfig
from sim_bridge.camera_frame import optical_from_mujoco
from sim_bridge.cloud import corrupt_depth, crop, voxel_downsample
from sim_bridge.depth_render import DepthSegRenderer
from sim_bridge.mjcf import DEPTH_CAMERA


def depth_scene_option() -> mujoco.MjvOption:
    """Render options of the depth camera: geoms of groups 0-2 only (no sites, frames or markers)."""
    option = mujoco.MjvOption()
    option.sitegroup[:] = 0
    return option


class DepthCamera:
    """Renders the named camera of a model into clouds.

    The OpenGL context is created on the first capture, in the calling thread, which must be the thread
    of every later capture.

    Args:
        model: the compiled scene (its camera `name` is posed per `config`).
        robot_geoms: (ngeom,) bool mask of the robot's geoms (removed when config.remove_robot).
        config: intrinsics, range and cloud processing.
        rng: source of depth noise and dropout.
    """

    def __init__(
        self,
        model: mujoco.MjModel,
        robot_geoms: np.ndarray,
        config: CameraConfig,
        rng: np.random.Generator,
        name: str = DEPTH_CAMERA,
    ):
        self.model = model
        self.config = config
        self.rng = rng
        self.camera_id = model.camera(name).id
        self._robot_geoms = np.asarray(robot_geoms, dtype=bool)
        self._rays = config.intrinsics.ray_directions(config.stride)
        self._option = depth_scene_option()
        self._renderer: DepthSegRenderer | None = None

    def capture(self, data: mujoco.MjData) -> tuple[np.ndarray, np.ndarray]:
        """Depth (H, W) float64 [m] along the optical axis and geom id (H, W) int32 (-1: no geom)."""
        if self._renderer is None:
            c = self.config
            self._renderer = DepthSegRenderer(self.model, self.camera_id, c.width, c.height, self._option)
        return self._renderer.render(data)

    def point_cloud(self, data: mujoco.MjData) -> np.ndarray:
        """The scene as points (N, 3) float32 [m] in world, robot removed, cropped and downsampled."""
        c = self.config
        depth, geom = self.capture(data)
        s = c.stride
        depth, geom = depth[::s, ::s], geom[::s, ::s]
        valid = (geom >= 0) & (depth >= c.min_depth) & (depth <= c.max_depth)
        if c.remove_robot:
            valid &= ~self._robot_geoms[np.maximum(geom, 0)]
        depth = corrupt_depth(np.where(valid, depth, np.nan), self.rng, c.depth_noise, c.dropout)
        points = unproject(depth, self._rays, self.pose(data))
        points = voxel_downsample(crop(points, np.asarray(c.crop_min), np.asarray(c.crop_max)), c.voxel_size)
        return points.astype(np.float32)

    def pose(self, data: mujoco.MjData) -> np.ndarray:
        """The camera's (4, 4) camera-to-world transform now, optical frame (data/camera.py)."""
        pose = np.eye(4)
        pose[:3, :3] = optical_from_mujoco(data.cam_xmat[self.camera_id].reshape(3, 3))
        pose[:3, 3] = data.cam_xpos[self.camera_id]
        return pose

    def close(self) -> None:
        """Release the OpenGL context (call from the capturing thread)."""
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None

"""Virtual depth images and point clouds of a scene by raycasting (open3d), robot not rendered; cameras as in
data/camera.py (optical frame)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from latent_planner_ros.data.camera import CameraConfig, CameraIntrinsics, sample_camera_pose, unproject
from latent_planner_ros.data.cloud_ops import crop
from latent_planner_ros.data.cloud_ops import voxel_downsample as float64_voxel_downsample
from latent_planner_ros.data.obstacle_geometry import triangle_mesh
from latent_planner_ros.data.scene import Scene

TABLE_TOP = ((-0.6, -1.2), (1.6, 1.2))
"""Rendered table top: (x_min, y_min), (x_max, y_max) [m] of the plane z = 0."""


def _table_mesh() -> tuple[np.ndarray, np.ndarray]:
    (x0, y0), (x1, y1) = TABLE_TOP
    v = np.array([[x0, y0, 0.0], [x1, y0, 0.0], [x1, y1, 0.0], [x0, y1, 0.0]])
    return v, np.array([[0, 1, 2], [0, 2, 3]])


def scene_triangles(scene: Scene, table: bool = True) -> tuple[np.ndarray, np.ndarray]:
    """All obstacle (and table) triangles of a scene: vertices (V, 3) [m], faces (F, 3)."""
    meshes = [triangle_mesh(o) for o in scene.obstacles] + ([_table_mesh()] if table else [])
    verts, faces, offset = [], [], 0
    for v, f in meshes:
        verts.append(v)
        faces.append(f + offset)
        offset += len(v)
    return np.concatenate(verts), np.concatenate(faces)


def render_depth(scene: Scene, pose: np.ndarray, intrinsics: CameraIntrinsics, table: bool = True) -> np.ndarray:
    """Depth image (H, W) float32 [m] along the camera's z axis; inf where the ray hits nothing.

    Args:
        pose: (4, 4) camera-to-world transform (optical frame: z forward, x right, y down).
    """
    import open3d as o3d  # heavy import, only needed to render

    v, f = scene_triangles(scene, table)
    rc = o3d.t.geometry.RaycastingScene()
    rc.add_triangles(o3d.core.Tensor.from_numpy(v.astype(np.float32)), o3d.core.Tensor.from_numpy(f.astype(np.uint32)))
    dirs_cam = intrinsics.ray_directions()  # (H, W, 3), unit z
    dirs = dirs_cam @ pose[:3, :3].T
    origins = np.broadcast_to(pose[:3, 3], dirs.shape)
    rays = np.concatenate([origins, dirs], -1).astype(np.float32)
    t = rc.cast_rays(o3d.core.Tensor.from_numpy(rays))["t_hit"].numpy()  # in units of the (unit-z) direction = depth
    return t.astype(np.float32)


def depth_to_points(depth: np.ndarray, pose: np.ndarray, intrinsics: CameraIntrinsics) -> np.ndarray:
    """Back-project the finite pixels of a depth image (H, W) [m] seen from `pose` (4, 4) into `world` points (N, 3)
    float32."""
    return unproject(depth, intrinsics.ray_directions(), pose).astype(np.float32)


def add_depth_noise(depth: np.ndarray, rng: np.random.Generator, sigma: float, quadratic: float) -> np.ndarray:
    """Depth (H, W) [m] plus Gaussian noise of standard deviation sigma + quadratic * depth^2 [m]."""
    if sigma <= 0.0 and quadratic <= 0.0:
        return depth
    finite = np.isfinite(depth)
    d = np.where(finite, depth, 0.0)
    noisy = d + rng.normal(size=d.shape) * (sigma + quadratic * d * d)
    return np.where(finite, noisy, np.inf).astype(np.float32)


def scene_view(
    scene: Scene, rng: np.random.Generator, config: CameraConfig | None = None, pose: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """A point cloud (N, 3) float32 in `world` [m] of the scene and table seen from one viewpoint, and the
    camera origin (3,) float [m] it was seen from.

    The viewpoint is sampled from the config's ranges unless `pose` (4, 4) is given; depth noise is drawn
    from rng; the cloud is cropped to the config's workspace box.
    """
    cfg = config or CameraConfig()
    pose = sample_camera_pose(rng, cfg) if pose is None else pose
    depth = render_depth(scene, pose, cfg.intrinsics)
    depth[depth > cfg.max_depth] = np.inf
    depth = add_depth_noise(depth, rng, cfg.depth_noise, cfg.depth_noise_quadratic)
    return crop(depth_to_points(depth, pose, cfg.intrinsics), cfg.crop_min, cfg.crop_max), pose[:3, 3].copy()


def scene_cloud(
    scene: Scene, rng: np.random.Generator, config: CameraConfig | None = None, pose: np.ndarray | None = None
) -> np.ndarray:
    """The cloud (N, 3) float32 [m] of scene_view, without the camera origin."""
    return scene_view(scene, rng, config, pose)[0]


def voxel_downsample(points: np.ndarray, size: float) -> np.ndarray:
    """One point per occupied cubic voxel of edge `size` [m] (the mean of its points), float32 (M, 3); the sim
    camera's downsampling (data/cloud_ops.voxel_downsample)."""
    if len(points) == 0 or size <= 0.0:
        return points
    return float64_voxel_downsample(points, size).astype(np.float32)


def fused_view(
    scene: Scene, rng: np.random.Generator, camera: CameraConfig, views: int
) -> tuple[np.ndarray, np.ndarray]:
    """`views` random views of a scene fused: the cloud (N, 3) float32 [m] and the camera origin of each point
    (N, 3); the views look at the centre of the scene's obstacles from all round (the default ranges)."""
    corners = np.concatenate([triangle_mesh(o)[0] for o in scene.obstacles]) if scene.obstacles else np.zeros((1, 3))
    centre = (corners.min(0) + corners.max(0)) / 2
    aimed = replace(camera, target=(float(centre[0]), float(centre[1]), float(centre[2])))
    clouds, eyes = zip(*(scene_view(scene, rng, aimed) for _ in range(views)), strict=True)
    origins = np.concatenate([np.repeat(e[None], len(c), 0) for c, e in zip(clouds, eyes, strict=True)])
    return np.concatenate(clouds).astype(np.float32), origins.reshape(-1, 3).astype(np.float32)

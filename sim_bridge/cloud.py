"""Depth image -> point cloud, pure numpy: unprojection, noise and dropout; cropping and voxel downsampling are the
core's (latent_planner_ros/data/cloud_ops.py), the same for every user of clouds."""

from __future__ import annotations

import numpy as np

from latent_planner_ros.data.cloud_ops import crop, voxel_downsample

__all__ = ["corrupt_depth", "crop", "pixel_rays", "unproject", "voxel_downsample"]


def pixel_rays(height: int, width: int, focal_px: float, stride: int = 1) -> np.ndarray:
    """Camera-frame directions (h', w', 3) with unit depth for the kept pixels (every stride-th).

    Camera frame (MuJoCo/OpenGL): x right, y up, the camera looks along -z; row 0 is the image top.
    A pixel at depth d [m] (distance along the optical axis) is at d * ray.
    """
    u = (np.arange(0, width, stride) + 0.5 - width / 2.0) / focal_px
    v = (np.arange(0, height, stride) + 0.5 - height / 2.0) / focal_px
    uu, vv = np.meshgrid(u, v)
    return np.stack([uu, -vv, -np.ones_like(uu)], axis=-1)


def corrupt_depth(depth: np.ndarray, rng: np.random.Generator, noise_at_1m: float, dropout: float) -> np.ndarray:
    """Depth (h, w) [m] with Gaussian noise (std noise_at_1m * depth^2) and a `dropout` fraction set to NaN."""
    out = np.array(depth, dtype=np.float64)
    if noise_at_1m > 0.0:
        out += rng.normal(size=out.shape) * noise_at_1m * out**2
    if dropout > 0.0:
        out[rng.uniform(size=out.shape) < dropout] = np.nan
    return out


def unproject(depth: np.ndarray, rays: np.ndarray, position: np.ndarray, rotation: np.ndarray) -> np.ndarray:
    """World points (N, 3) float64 of the pixels with finite depth.

    Args:
        depth: (h, w) [m] along the optical axis; NaN = no return.
        rays: (h, w, 3) from :func:`pixel_rays` (same decimation as depth).
        position: (3,) camera centre in world [m]; rotation: (3, 3) camera-to-world rotation.
    """
    keep = np.isfinite(depth)
    cam = rays[keep] * depth[keep][:, None]
    return cam @ np.asarray(rotation).T + np.asarray(position)

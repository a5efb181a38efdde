"""Depth image noise and dropout for the sim's cameras, pure numpy; unprojection is the camera model's
(latent_planner_ros/data/camera.py), cropping and voxel downsampling are the core's
(latent_planner_ros/data/cloud_ops.py), the same for every user of clouds."""

from __future__ import annotations

import numpy as np

from latent_planner_ros.data.cloud_ops import crop, voxel_downsample

__all__ = ["corrupt_depth", "crop", "voxel_downsample"]


def corrupt_depth(depth: np.ndarray, rng: np.random.Generator, noise_at_1m: float, dropout: float) -> np.ndarray:
    """Depth (h, w) [m] with Gaussian noise (std noise_at_1m * depth^2) and a `dropout` fraction set to NaN."""
    out = np.array(depth, dtype=np.float64)
    if noise_at_1m > 0.0:
        out += rng.normal(size=out.shape) * noise_at_1m * out**2
    if dropout > 0.0:
        out[rng.uniform(size=out.shape) < dropout] = np.nan
    return out

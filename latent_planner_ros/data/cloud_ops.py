"""Point-cloud operations shared by the sim's cameras, the collision data, the scene encoder and the planners:
the workspace box that covers the arm's reach, cropping, voxel downsampling. Pure numpy."""

from __future__ import annotations

import numpy as np

REACH_CROP_MIN = (-1.0, -1.0, -0.02)
"""[m] lower corner in `world` of the box that covers the Panda's reach all around its base (|x|, |y| <= 1 m)"""
REACH_CROP_MAX = (1.0, 1.0, 1.3)
"""[m] upper corner of that box: 1.3 m up (the Panda reaches about 1.19 m above its base), so nothing the arm can
hit is cropped away (the sim cameras' default crop, and the clouds the benches give the planners)"""


def crop(points: np.ndarray, low, high) -> np.ndarray:
    """The points (N, 3) inside the closed axis-aligned box [low, high] [m] (low, high: (3,))."""
    inside = np.all((points >= np.asarray(low)) & (points <= np.asarray(high)), axis=1)
    return points[inside]


def voxel_downsample(points: np.ndarray, voxel_size: float) -> np.ndarray:
    """One point per occupied voxel of edge voxel_size [m] (the mean of its points), (M, 3) float64, M <= N; the
    points themselves when voxel_size <= 0 or there are none.

    The output order follows the voxels' sorted integer coordinates, so it is deterministic.
    """
    if voxel_size <= 0.0 or len(points) == 0:
        return points
    points = np.asarray(points, dtype=np.float64)
    keys = np.floor(points / voxel_size).astype(np.int64)
    keys -= keys.min(axis=0)
    dims = keys.max(axis=0) + 1
    linear = (keys[:, 0] * dims[1] + keys[:, 1]) * dims[2] + keys[:, 2]
    _, inverse, counts = np.unique(linear, return_inverse=True, return_counts=True)
    sums = [np.bincount(inverse, weights=points[:, k], minlength=len(counts)) for k in range(3)]
    return np.stack(sums, axis=1) / counts[:, None]

"""Whether a scene lies where the collision network was trained: the share of it outside the network's box.

The shipped network learned tabletop scenes inside its workspace box. A workcell (shelves, bins, cages, walls
all around the base) puts most of the scene outside that box, where the network is never given the points and
refuses free space it has not seen the like of; the learned backend then plans with the geometric backend
instead (planning/learned_backend.py), and says so.
"""

from __future__ import annotations

import numpy as np

VOXEL_M = 0.1
"""edge [m] of the voxels the share is counted in"""
FLOOR_M = 0.02
"""points below this height [m] (the table top, checked exactly) are not part of the scene here"""
MIN_POINTS = 3
"""a voxel counts as occupied with at least this many points (stray depth noise far away does not)"""


def share_outside(cloud: np.ndarray, bounds_min, bounds_max) -> float:
    """The share in [0, 1] of the occupied VOXEL_M voxels above FLOOR_M whose centre lies outside the box
    [bounds_min, bounds_max] (3,) [m]; 0 for a cloud (N, 3) [m] with nothing above the floor."""
    pts = np.asarray(cloud, dtype=np.float32).reshape(-1, 3)
    pts = pts[np.isfinite(pts).all(axis=1) & (pts[:, 2] >= FLOOR_M)]
    cells = np.floor(pts / VOXEL_M).astype(np.int64)
    centres = (cells + 0.5) * VOXEL_M
    outside = np.any((centres < np.asarray(bounds_min)) | (centres > np.asarray(bounds_max)), axis=1)
    if not outside.any():  # the usual tabletop: no need to count the occupied voxels
        return 0.0
    cells += 1024  # non-negative, 11 bits per axis: one int64 key per voxel
    keys, first, counts = np.unique(
        (cells[:, 0] << 22) | (cells[:, 1] << 11) | cells[:, 2], return_index=True, return_counts=True
    )
    occupied = counts >= MIN_POINTS
    if not occupied.any():
        return 0.0
    return float(outside[first[occupied]].mean())

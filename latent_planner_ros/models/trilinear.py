"""Trilinear sampling of a voxel feature grid without autograd, for the hard checks of many configurations.

`torch.nn.functional.grid_sample` on a 3D grid walks the channels of every sample point separately and is
slow on the CPU for small grids with many channels. Without gradients the same numbers come from one fused
`embedding_bag`: each point sums the feature rows (channels last) of its 8 neighbouring voxel centres with
its trilinear weights, the corner indices and weights computed in numpy. The convention is grid_sample's with
align_corners=False and zero padding: a voxel's value sits at its centre and the grid is 0 outside.
"""

from __future__ import annotations

import numpy as np
import torch
import torch.nn.functional as F


def channels_last(features: torch.Tensor) -> torch.Tensor:
    """Rows (nx * ny * nz, C) float32 of a grid (C, nx, ny, nz), x-major voxel order."""
    return features.detach().reshape(features.shape[0], -1).T.contiguous().float()


def sample(table: torch.Tensor, shape: tuple[int, int, int], cells: np.ndarray) -> torch.Tensor:
    """Trilinear samples (P, C) float32 of the grid whose rows `table` (nx * ny * nz, C) are, at continuous
    voxel indices cells (P, 3) (voxel i's centre at index i; zero outside the grid)."""
    f = np.ascontiguousarray(np.asarray(cells, dtype=np.float64).T)  # (3, P): numpy is slow along rows of 3
    n = np.asarray(shape)[:, None]
    lo = np.floor(f)
    t = f - lo
    lo = lo.astype(np.intp)
    corner = np.stack([lo, lo + 1])  # (2, 3, P): both neighbours along each axis
    weight = np.stack([1.0 - t, t])
    weight[(corner < 0) | (corner >= n)] = 0.0  # a neighbour outside the grid adds nothing (zero padding)
    np.minimum(np.maximum(corner, 0, out=corner), n - 1, out=corner)  # any valid row (np.clip is slower)
    _, ny, nz = shape
    i, j, k = corner[:, 0], corner[:, 1], corner[:, 2]  # (2, P) each
    flat = (i[:, None, None] * ny + j[None, :, None]) * nz + k[None, None, :]  # (2, 2, 2, P)
    wi, wj, wk = weight[:, 0], weight[:, 1], weight[:, 2]
    w = wi[:, None, None] * wj[None, :, None] * wk[None, None, :]
    return F.embedding_bag(
        torch.from_numpy(np.ascontiguousarray(flat.reshape(8, -1).T)),
        table,
        per_sample_weights=torch.from_numpy(np.ascontiguousarray(w.reshape(8, -1).T, dtype=np.float32)),
        mode="sum",
    )

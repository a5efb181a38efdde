"""Exact "is any cloud point inside this sphere?" for many spheres at once.

A KD-tree answers it exactly, but a bounded nearest-point query still costs about a microsecond per sphere,
and the arm has 66 spheres per configuration. Nearly all of them are far from every point, so a cheap exact
filter goes first: the cloud's occupancy on a grid of `cell` [m] voxels, as a 3D prefix sum, counts the
occupied voxels that overlap each sphere's bounding box in eight lookups. A sphere whose box holds no point
is free; only the rest (typically under 1 %) go to the KD-tree. The answer equals the KD-tree's alone.

Callers that decide exactly later use the two bounds alone: `maybe_occupied` (the bounding-box count: False only
where no point is inside) and `surely_occupied` (an occupied voxel wholly inside the sphere's inscribed cube: True
only where a point is inside).
"""

from __future__ import annotations

import numpy as np
import torch
from scipy.spatial import cKDTree

MAX_CELLS = 2_000_000
"""largest occupancy grid (voxels); a cloud spread wider gets coarser voxels"""


def finite_rows(points: np.ndarray) -> np.ndarray:
    """(N,) bool: the rows of points (N, 3) with three finite coordinates (np.all(..., axis=1) is slow on rows of 3)."""
    return np.isfinite(points[:, 0]) & np.isfinite(points[:, 1]) & np.isfinite(points[:, 2])


class BallQuery:
    """Point cloud (N, 3) [m] indexed for sphere-containment queries.

    Args:
        cloud: (N, 3) finite points [m].
        cell: voxel edge [m] of the occupancy prefilter (larger if the grid would exceed MAX_CELLS voxels).
    """

    def __init__(self, cloud: np.ndarray, cell: float = 0.02):
        self.cloud = np.asarray(cloud, dtype=float).reshape(-1, 3)
        self.cell = float(cell)
        self._tree: cKDTree | None = None
        if not len(self.cloud):
            return
        ct = np.ascontiguousarray(self.cloud.T)  # (3, N): numpy is slow along rows of 3
        lo, hi = ct.min(axis=1), ct.max(axis=1)
        cells = float(np.prod((hi - lo) / self.cell + 3))
        while cells > MAX_CELLS:  # a cloud spread far (outliers): coarser voxels keep the grid small, answers exact
            # (repeated: a cloud spread along one axis only shrinks by less than the cube root per pass)
            self.cell *= max((cells / MAX_CELLS) ** (1 / 3), 1.5)
            cells = float(np.prod((hi - lo) / self.cell + 3))
        self._lo = lo - self.cell
        ijk = np.floor((ct - self._lo[:, None]) / self.cell).astype(np.intp)
        shape = ijk.max(axis=1) + 2
        occ = np.zeros(shape, dtype=np.int32)
        occ[ijk[0], ijk[1], ijk[2]] = 1
        prefix = np.zeros(shape + 1, dtype=np.int32)  # prefix[i, j, k] = occupied voxels in [:i, :j, :k]
        prefix[1:, 1:, 1:] = torch.from_numpy(occ).cumsum(0).cumsum_(1).cumsum_(2).numpy()  # numpy's: 3x slower
        self._prefix = prefix
        self._strides = np.asarray(prefix.strides, dtype=np.intp) // prefix.itemsize
        self._top = np.asarray(prefix.shape) - 1

    def _kdtree(self) -> cKDTree:
        if self._tree is None:  # built on first need: most plans never ask the exact question
            # unbalanced, non-compact: about half the build time of scipy's default, the same exact answers
            self._tree = cKDTree(self.cloud, balanced_tree=False, compact_nodes=False)
        return self._tree

    def maybe_occupied(self, centres: np.ndarray, radii: np.ndarray) -> np.ndarray:
        """(M,) bool: False only where no cloud point lies inside the sphere (centres (M, 3) [m], radii (M,) [m]):
        the occupancy prefilter alone (True: a point lies in a voxel that overlaps the sphere's bounding box, or
        the centre is not finite). A filter for callers that decide exactly later (`occupied` does so itself)."""
        centres = np.asarray(centres, dtype=float).reshape(-1, 3)
        radii = np.broadcast_to(np.asarray(radii, dtype=float), (len(centres),))
        return self._box_counts(np.ascontiguousarray(centres.T), radii) > 0

    def surely_occupied(self, centres: np.ndarray, radii: np.ndarray) -> np.ndarray:
        """(M,) bool: True only where a cloud point lies strictly inside the sphere (centres (M, 3) [m], radii (M,)
        [m]): an occupied voxel lies wholly inside the cube inscribed in the sphere (no KD-tree; False says
        nothing)."""
        centres = np.asarray(centres, dtype=float).reshape(-1, 3)
        radii = np.broadcast_to(np.asarray(radii, dtype=float), (len(centres),))
        if not len(self.cloud) or not len(centres):
            return np.zeros(len(centres), dtype=bool)
        ct = np.ascontiguousarray(centres.T)
        ok = np.isfinite(ct).all(axis=0)
        ct = np.where(ok, ct, 0.0)
        u = (ct - self._lo[:, None]) / self.cell  # (3, M) [voxels]
        h = radii * (1.0 - 1e-6) / (np.sqrt(3.0) * self.cell) - 1e-6  # the inscribed cube's half side [voxels]
        top = self._top[:, None]
        a = np.minimum(np.maximum(np.ceil(u - h).astype(np.intp), 0), top)  # first voxel wholly inside
        b = np.minimum(np.maximum(np.floor(u + h).astype(np.intp), 0), top)  # one past the last
        return ok & (b > a).all(axis=0) & (self._count(a, b) > 0)

    def _count(self, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        """(M,) occupied voxels in the boxes [a, b) of voxel indices a, b (3, M) (clipped to the prefix grid)."""
        a = a * self._strides[:, None]  # flat offsets of the box corners along each axis
        b = b * self._strides[:, None]
        p = self._prefix.ravel()
        (x0, y0, z0), (x1, y1, z1) = a, b
        xy11, xy01, xy10, xy00 = x1 + y1, x0 + y1, x1 + y0, x0 + y0
        return (
            p[xy11 + z1] - p[xy01 + z1] - p[xy10 + z1] - p[xy11 + z0]
            + p[xy00 + z1] + p[xy01 + z0] + p[xy10 + z0] - p[xy00 + z0]
        )  # fmt: skip

    def _box_counts(self, ct: np.ndarray, radii: np.ndarray) -> np.ndarray:
        """(M,) occupied voxels overlapping each sphere's bounding box (centres ct (3, M) [m], radii (M,) [m]);
        a non-finite centre counts 1 (refused, as `occupied` refuses it)."""
        bad = ~np.isfinite(ct).all(axis=0)
        if not len(self.cloud) or not ct.shape[1]:
            return bad.astype(np.int32)
        if bad.any():
            ct = np.where(bad, 0.0, ct)
        inv = 1.0 / self.cell
        u = (ct - self._lo[:, None]) * inv  # (3, M) [voxels]
        r = radii * inv + 1e-6  # widened by a hair: rounding never shrinks the box below the sphere's
        top = self._top[:, None]
        a = np.floor(u - r).astype(np.intp)
        b = np.floor(u + r).astype(np.intp) + 1
        np.minimum(np.maximum(a, 0, out=a), top, out=a)  # np.clip costs more than both at this size
        np.minimum(np.maximum(b, 0, out=b), top, out=b)
        count = self._count(a, b)
        count[bad] = 1
        return count

    def occupied(self, centres: np.ndarray, radii: np.ndarray) -> np.ndarray:
        """(M,) bool: True where a cloud point lies strictly inside the sphere (centres (M, 3) [m], radii (M,) [m]);
        also True for a non-finite centre."""
        centres = np.asarray(centres, dtype=float).reshape(-1, 3)
        radii = np.broadcast_to(np.asarray(radii, dtype=float), (len(centres),))
        ct = np.ascontiguousarray(centres.T)  # (3, M): every operation below runs along M (numpy is slow on rows of 3)
        hit = ~np.isfinite(ct).all(axis=0)
        if not len(self.cloud) or not len(centres):
            return hit
        cand = np.flatnonzero((self._box_counts(ct, radii) > 0) & ~hit)
        if len(cand):
            bound = float(radii[cand].max()) + 1e-9
            d, _ = self._kdtree().query(ct[:, cand].T, distance_upper_bound=bound)
            hit[cand] |= d < radii[cand]
        return hit

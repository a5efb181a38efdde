"""The target of a grasp goal, found in the point cloud: the object between the open fingers at the goal pose.

A grasp goal puts the TCP (`panda_hand_tcp`, between the fingertips) at an object with the open fingers around
it, so the object's points lie inside the hand: every planner would call the goal blocked. As MoveIt's allowed
collisions of a target object, those points are set aside (they stop counting as obstacles); every other
point stays. Which points are the target:

1. **seeds**: the points inside the gripper's closing region at the goal (a box in the hand frame between the
   open fingers, from the palm to the fingertips, grown by `closing_grow`);
2. **growth**: points connected to the seeds through the cloud (neighbours within `link_radius`), only within
   `reach_radius` of the TCP (the gripper cannot hold more of an object than that);
3. **support**: the growth never enters the surface the object stands on. Points below the lowest seed whose
   local normal is vertical (PCA of `normal_neighbours` neighbours) are the support (a shelf board, a bin floor,
   a table); its top height is the median height of those within 1 cm of the highest of them, and no point
   lower than that plus `support_margin` is target (gravity is world -z: the base frame stands upright).

A caller who knows the object instead gives a radius about the TCP (every point within it is target) or a box
(`TargetBox`, every point inside it is target); no growth then.

Limits: an object within `link_radius` of another non-support surface (a wall behind it) would take that
surface's points too (the reach radius bounds how many); the benchmark's grasp problems keep objects 2 cm from
every surface but their support.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

CLOSING_LO = (-0.011, -0.04, -0.0374)
"""[m] lower corner of the open gripper's closing region in the TCP frame: finger width (x), the inner faces of
the open fingers 8 cm apart (y), the palm (z; the hand's z axis is the approach direction)"""
CLOSING_HI = (0.011, 0.04, 0.0095)
"""[m] upper corner of the closing region in the TCP frame (z: the fingertips)"""


@dataclass(frozen=True)
class GraspTargetConfig:
    """How the target is found in the cloud (see the module docstring)."""

    closing_grow: float = 0.005
    """[m] the closing region box is grown by this on every side (depth noise)"""
    link_radius: float = 0.012
    """[m] points this close to a target point are the same object"""
    reach_radius: float = 0.07
    """[m] no point farther than this from the TCP is target (the gripper's reach)"""
    support_margin: float = 0.005
    """[m] points lower than the support's top plus this are never target"""
    normal_neighbours: int = 10
    """neighbours of the local normal estimate (PCA)"""
    vertical_cos: float = 0.85
    """a normal is vertical when |n_z| exceeds this"""

    def __post_init__(self) -> None:
        for name in ("closing_grow", "link_radius", "reach_radius", "support_margin"):
            v = getattr(self, name)
            if not (np.isfinite(v) and v >= 0):
                raise ValueError(f"{name} must be a non-negative number of metres, got {v!r}")
        if self.normal_neighbours < 3:
            raise ValueError(f"normal_neighbours must be >= 3, got {self.normal_neighbours!r}")


@dataclass(frozen=True)
class TargetBox:
    """A caller's box around the target: centre (3,) [m] and rotation (3, 3) in the cloud's frame, half
    extents (3,) [m] along the box axes."""

    centre: np.ndarray
    rotation: np.ndarray
    half_extents: np.ndarray

    def contains(self, points: np.ndarray) -> np.ndarray:
        """(N,) bool: which of points (N, 3) [m] lie inside."""
        local = (np.asarray(points, dtype=float) - np.asarray(self.centre)) @ np.asarray(self.rotation)
        return np.all(np.abs(local) <= np.asarray(self.half_extents), axis=1)


@dataclass(frozen=True)
class TargetSplit:
    """The cloud split at a grasp goal.

    Attributes:
        obstacles: (N - K, 3) [m] the cloud without the target points (same dtype, same order).
        target: (K, 3) [m] the target points.
        mask: (N,) bool, True for a target point of the input cloud.
        seeds: how many target points lay in the closing region (caller-given target: all of them).
        support_z: [m] height below which nothing was target (the support's top plus the margin), or None.
        report: what was set aside and why (for the plan result and the node's status).
    """

    obstacles: np.ndarray
    target: np.ndarray
    mask: np.ndarray
    seeds: int
    support_z: float | None
    report: str

    @property
    def count(self) -> int:
        return int(self.mask.sum())


def closing_mask(points: np.ndarray, position: np.ndarray, rotation: np.ndarray, grow: float) -> np.ndarray:
    """(N,) bool: points (N, 3) [m] inside the closing region (grown by `grow` [m]) of a TCP at position (3,)
    [m] with rotation (3, 3) (columns: the hand's axes in the cloud's frame)."""
    local = (np.asarray(points, dtype=float) - np.asarray(position, dtype=float)) @ np.asarray(rotation, dtype=float)
    lo, hi = np.asarray(CLOSING_LO) - grow, np.asarray(CLOSING_HI) + grow
    return np.all((local >= lo) & (local <= hi), axis=1)


def vertical_normals(points: np.ndarray, k: int, cos: float) -> np.ndarray:
    """(N,) bool: whether the local surface normal (PCA of k neighbours) at each of points (N, 3) [m] is within
    acos(cos) of vertical."""
    if len(points) < 3:
        return np.zeros(len(points), dtype=bool)
    _, idx = cKDTree(points).query(points, k=min(k, len(points)))
    nb = points[idx] - points[idx].mean(axis=1, keepdims=True)
    _, vecs = np.linalg.eigh(np.einsum("nki,nkj->nij", nb, nb))
    return np.abs(vecs[:, 2, 0]) > cos  # the eigenvector of the smallest eigenvalue, its z component


def split_target(
    cloud: np.ndarray,
    position: np.ndarray,
    rotation: np.ndarray,
    config: GraspTargetConfig | None = None,
    radius: float | None = None,
    box: TargetBox | None = None,
) -> TargetSplit:
    """Split cloud (N, 3) [m] (robot base frame, z up) at a grasp goal: TCP at position (3,) [m], hand rotation
    (3, 3). The target is found as in the module docstring, or is every point within `radius` [m] of the TCP, or
    inside `box` (not both)."""
    cfg = config or GraspTargetConfig()
    cloud = np.asarray(cloud).reshape(-1, 3)
    pts = cloud.astype(float)
    position = np.asarray(position, dtype=float)
    if radius is not None and box is not None:
        raise ValueError("give a target radius or a target box, not both")
    mask = np.zeros(len(pts), dtype=bool)
    ok = np.all(np.isfinite(pts), axis=1)
    if radius is not None or box is not None:
        if box is not None:
            mask[ok] = box.contains(pts[ok])
            why = "inside the given box"
        else:
            assert radius is not None
            mask[ok] = np.linalg.norm(pts[ok] - position, axis=1) <= radius
            why = f"within the given radius {radius * 100:g} cm of the TCP"
        n = int(mask.sum())
        return TargetSplit(cloud[~mask], cloud[mask], mask, n, None, f"{n} target points set aside ({why})")
    near = np.flatnonzero(ok & (np.linalg.norm(np.where(ok[:, None], pts, 0.0) - position, axis=1) <= cfg.reach_radius))
    local = pts[near]
    seed = closing_mask(local, position, rotation, cfg.closing_grow)
    if not seed.any():
        return TargetSplit(cloud, cloud[:0], mask, 0, None, "no target: no point in the closing region")
    z_low = float(local[seed, 2].min())
    below = local[:, 2] < z_low
    support = np.zeros(len(local), dtype=bool)
    support[below] = vertical_normals(local, cfg.normal_neighbours, cfg.vertical_cos)[below]
    support_z = None
    allowed = np.ones(len(local), dtype=bool)
    if support.any():
        zs = local[support, 2]
        support_z = float(np.median(zs[zs >= zs.max() - 0.01])) + cfg.support_margin
        allowed = local[:, 2] >= support_z
    seed &= allowed
    member = seed.copy()
    tree = cKDTree(local)
    frontier = np.flatnonzero(seed)
    while len(frontier):
        found = tree.query_ball_point(local[frontier], cfg.link_radius)
        nxt = np.unique(np.concatenate([np.asarray(f, dtype=int) for f in found]))
        nxt = nxt[allowed[nxt] & ~member[nxt]]
        member[nxt] = True
        frontier = nxt
    mask[near[member]] = True
    n, s = int(member.sum()), int(seed.sum())
    report = (
        f"{n} target points set aside: {s} in the closing region, {n - s} connected to them within "
        f"{cfg.reach_radius * 100:g} cm of the TCP"
        + (f"; none below z = {support_z:.3f} m (the support)" if support_z is not None else "")
    )
    return TargetSplit(cloud[~mask], cloud[mask], mask, s, support_z, report)

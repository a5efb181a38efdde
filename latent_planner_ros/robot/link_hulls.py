"""The convex hull of each link's collision geometry as half-spaces, for exact point-against-link tests.

A hull contains its link's meshes (the union of a frame's geometry objects), so a point farther than a margin
from every hull is farther than that margin from the robot's collision geometry.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np
from scipy.spatial import ConvexHull

from latent_planner_ros.robot.panda import LINK_FRAMES
from latent_planner_ros.robot.spheres import link_geometry_objects


def link_vertices() -> dict[str, np.ndarray]:
    """The vertices (N, 3) [m] of each link's collision geometry in its link frame: mesh vertices and box corners
    (so their hull contains the geometry exactly)."""
    out: dict[str, list[np.ndarray]] = {}
    for name, geo, to_frame in link_geometry_objects():
        if hasattr(geo, "vertices"):
            local = np.asarray(geo.vertices())
        elif hasattr(geo, "halfSide"):
            corners = np.array([[i, j, k] for i in (-1, 1) for j in (-1, 1) for k in (-1, 1)], dtype=float)
            local = corners * np.asarray(geo.halfSide)
        else:
            raise NotImplementedError(f"no vertices for {type(geo).__name__} ({name})")
        out.setdefault(name, []).append(local @ to_frame.rotation.T + to_frame.translation)
    return {k: np.concatenate(v) for k, v in out.items()}


@lru_cache(maxsize=1)
def link_hull_planes() -> dict[int, np.ndarray]:
    """Per index into LINK_FRAMES, the hull's facet planes (F, 4) in the link frame: a point x [m] lies inside
    iff n . x + d <= 0 for every row (n, d), n a unit outward normal. Deterministic; computed once."""
    return {LINK_FRAMES.index(name): ConvexHull(p).equations for name, p in link_vertices().items()}


def plane_distance(planes: np.ndarray, points: np.ndarray) -> np.ndarray:
    """max over facets of n . x + d for points (N, 3) [m] in the link frame, (N,): <= 0 inside the hull, and a lower
    bound of the distance [m] to it outside (the exact distance off the hull's faces, less near edges and
    corners), so `plane_distance(...) <= margin` keeps every point within `margin` of the hull."""
    return (points @ planes[:, :3].T + planes[:, 3]).max(axis=1)

"""The convex hull of each link's collision geometry as half-spaces, for exact point-against-link tests.

A hull contains its link's meshes (the union of a frame's geometry objects), so a point farther than a margin
from every hull is farther than that margin from the robot's collision geometry.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np
from scipy.spatial import ConvexHull, cKDTree

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


HULL_SPHERES_PER_LINK = 24
"""spheres per link covering its hull (the hard check's prefilter)"""


@lru_cache(maxsize=1)
def hull_cover_spheres() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Spheres whose union covers each moving link's convex hull: (link index into LINK_FRAMES (S,), centre in
    the link frame (S, 3) [m], radius (S,) [m]). k-means over points spread over each hull's surface and a
    grid of its interior; each radius reaches the farthest of its points plus the largest gap between
    neighbouring surface points, so no point of the hull lies outside the union. Deterministic; computed once.

    (The sphere model of robot/spheres.py is fitted to the mesh vertices and leaves parts of the hull
    surfaces outside its spheres, up to 9 cm on panda_link5: a prefilter for the hull test must not.)"""
    from scipy.cluster.vq import kmeans2

    rng = np.random.default_rng(0)
    links, centres, radii = [], [], []
    for name, vertices in link_vertices().items():
        if name == "panda_link0":  # stands on the table
            continue
        hull = ConvexHull(vertices)
        tri = vertices[hull.simplices]
        area = 0.5 * np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
        n = 6000
        idx = rng.choice(len(tri), n, p=area / area.sum())
        a, b = rng.random((2, n, 1))
        flip = a + b > 1
        a, b = np.where(flip, 1 - a, a), np.where(flip, 1 - b, b)
        surface = tri[idx, 0] + a * (tri[idx, 1] - tri[idx, 0]) + b * (tri[idx, 2] - tri[idx, 0])
        nearest_two = np.asarray(cKDTree(surface).query(surface, k=2)[0])
        gap = float(nearest_two[:, 1].max())  # farthest a surface point is from a sample
        k = min(HULL_SPHERES_PER_LINK, len(surface))
        centre, label = kmeans2(surface, k, seed=rng, minit="++")
        for j in range(k):
            members = surface[label == j]
            if len(members):
                links.append(LINK_FRAMES.index(name))
                centres.append(centre[j])
                radii.append(float(np.linalg.norm(members - centre[j], axis=1).max()) + gap)
    return np.asarray(links), np.asarray(centres), np.asarray(radii)


HULL_INNER_BALLS_PER_LINK = 4
"""balls inside each link's hull (the hard check's sure hits)"""


@lru_cache(maxsize=1)
def hull_inner_balls() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Balls that lie inside each moving link's convex hull: (link index into LINK_FRAMES (B,), centre in the
    link frame (B, 3) [m], radius (B,) [m]). A point within radius + m of a centre is within m of the hull, so an
    observed point there refuses the configuration without a nearest-point search. Greedy over a 1 cm grid of
    the hull's interior: the deepest point first, then the deepest outside the balls chosen (depth = distance
    to the nearest facet plane, exact inside a convex hull). Deterministic; computed once."""
    links, centres, radii = [], [], []
    for name, vertices in link_vertices().items():
        if name == "panda_link0":  # stands on the table
            continue
        planes = link_hull_planes()[LINK_FRAMES.index(name)]
        axes = [np.arange(lo, hi, 0.01) for lo, hi in zip(vertices.min(axis=0), vertices.max(axis=0), strict=True)]
        grid = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
        depth = -plane_distance(planes, grid)
        grid, depth = grid[depth > 0], depth[depth > 0]
        for _ in range(HULL_INNER_BALLS_PER_LINK):
            if not len(grid):
                break
            j = int(np.argmax(depth))
            links.append(LINK_FRAMES.index(name))
            centres.append(grid[j])
            radii.append(float(depth[j]))
            keep = np.linalg.norm(grid - grid[j], axis=1) > depth[j]
            grid, depth = grid[keep], depth[keep]
    return np.asarray(links), np.asarray(centres), np.asarray(radii)

"""Random object shapes in a local frame (centred near the origin, before placement on the table).

Training families are single convex primitives; the held-out family (composites.py) is never used in training.
Every sampler takes a Generator and a size scale s (1.0 = nominal) and returns a list of obstacles.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import ConvexHull

from latent_planner_ros.data.obstacles import Box, Capsule, Cylinder, Mesh, Obstacle, Sphere

_ORIGIN = (0.0, 0.0, 0.0)
_IDENTITY = (0.0, 0.0, 0.0, 1.0)


def box(rng: np.random.Generator, s: float = 1.0) -> list[Obstacle]:
    """A box with half extents 2-12 cm (up to 20 cm high)."""
    he = s * rng.uniform([0.02, 0.02, 0.02], [0.12, 0.12, 0.2])
    return [Box(_ORIGIN, _IDENTITY, tuple(float(x) for x in he))]


def cylinder(rng: np.random.Generator, s: float = 1.0) -> list[Obstacle]:
    """An upright cylinder: radius 2-8 cm, half length 3-20 cm."""
    return [Cylinder(_ORIGIN, _IDENTITY, float(s * rng.uniform(0.02, 0.08)), float(s * rng.uniform(0.03, 0.2)))]


def sphere(rng: np.random.Generator, s: float = 1.0) -> list[Obstacle]:
    """A sphere of radius 3-10 cm."""
    return [Sphere(_ORIGIN, float(s * rng.uniform(0.03, 0.1)))]


def capsule(rng: np.random.Generator, s: float = 1.0) -> list[Obstacle]:
    """A capsule: radius 2-6 cm, axis half length 3-15 cm."""
    return [Capsule(_ORIGIN, _IDENTITY, float(s * rng.uniform(0.02, 0.06)), float(s * rng.uniform(0.03, 0.15)))]


def convex_hull(rng: np.random.Generator, s: float = 1.0) -> list[Obstacle]:
    """The convex hull of 6-20 random points in an anisotropic box of half size 3-12 cm."""
    half = s * rng.uniform(0.03, 0.12, size=3)
    pts = rng.uniform(-half, half, size=(int(rng.integers(6, 21)), 3))
    hull = ConvexHull(pts)
    used = np.unique(hull.simplices)
    remap = np.full(len(pts), -1)
    remap[used] = np.arange(len(used))
    v = pts[used] - pts[used].mean(0)
    faces = remap[hull.simplices]
    # scipy does not orient simplices: make every normal point away from the centroid.
    tri = v[faces]
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    flip = np.einsum("ij,ij->i", n, tri.mean(1)) < 0
    faces[flip] = faces[flip][:, ::-1]
    return [Mesh(vertices=v, faces=faces.astype(np.int64))]


TRAIN_SHAPES = {
    "box": box,
    "cylinder": cylinder,
    "sphere": sphere,
    "capsule": capsule,
    "convex_hull": convex_hull,
}

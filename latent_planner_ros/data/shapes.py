"""Random object shapes in a local frame (centred near the origin, before placement on the table).

Training families are single convex primitives; the held-out family (composites.py) is never used in training.
Every sampler takes a Generator and a size scale s (1.0 = nominal) and returns a list of obstacles.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import ConvexHull

from latent_planner_ros.data.obstacles import Box, Capsule, Cylinder, Mesh, Obstacle, Sphere, vec3

_ORIGIN = (0.0, 0.0, 0.0)
_IDENTITY = (0.0, 0.0, 0.0, 1.0)

SHAPES_VERSION = 2
"""Version of the size distributions below, recorded in every dataset shard.
1: sizes uniform within the ranges; 2: log-uniform, down to thin plates and rods (1-2 cm thick)."""

THIN_PROB = 0.3
"""probability that a box is a plate or a bar (one or two half extents of 0.6-2 cm)"""


def _log_uniform(rng: np.random.Generator, lo, hi, size: int | None = None):
    return np.exp(rng.uniform(np.log(lo), np.log(hi), size))


def box(rng: np.random.Generator, s: float = 1.0) -> list[Obstacle]:
    """A box with half extents 1-12 cm (up to 20 cm high); sometimes a plate or bar 1.2-4 cm thick."""
    he = _log_uniform(rng, [0.01, 0.01, 0.01], [0.12, 0.12, 0.2], 3)
    if rng.random() < THIN_PROB:
        thin = rng.choice(3, size=int(rng.integers(1, 3)), replace=False)
        he[thin] = rng.uniform(0.006, 0.02, len(thin))
    return [Box(_ORIGIN, _IDENTITY, vec3(s * he))]


def cylinder(rng: np.random.Generator, s: float = 1.0) -> list[Obstacle]:
    """An upright cylinder: radius 0.8-8 cm (rods to cans), half length 2-22 cm."""
    return [Cylinder(_ORIGIN, _IDENTITY, float(s * _log_uniform(rng, 0.008, 0.08)), float(s * rng.uniform(0.02, 0.22)))]


def sphere(rng: np.random.Generator, s: float = 1.0) -> list[Obstacle]:
    """A sphere of radius 2-10 cm."""
    return [Sphere(_ORIGIN, float(s * _log_uniform(rng, 0.02, 0.1)))]


def capsule(rng: np.random.Generator, s: float = 1.0) -> list[Obstacle]:
    """A capsule: radius 0.8-6 cm, axis half length 3-15 cm."""
    return [Capsule(_ORIGIN, _IDENTITY, float(s * _log_uniform(rng, 0.008, 0.06)), float(s * rng.uniform(0.03, 0.15)))]


def convex_hull(rng: np.random.Generator, s: float = 1.0) -> list[Obstacle]:
    """The convex hull of 6-20 random points in an anisotropic box of half size 1-12 cm."""
    half = s * _log_uniform(rng, 0.01, 0.12, 3)
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

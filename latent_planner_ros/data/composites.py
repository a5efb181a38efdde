"""Held-out object family: non-convex composites made of several primitives (never used in training).

Each sampler returns the parts in a local frame with z up and the object standing on z = 0.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from latent_planner_ros.data.obstacles import Box, Capsule, Cylinder, Obstacle, quat_xyzw, vec3

_IDENTITY = (0.0, 0.0, 0.0, 1.0)


def _box(cx: float, cy: float, cz: float, hx: float, hy: float, hz: float) -> Box:
    return Box((float(cx), float(cy), float(cz)), _IDENTITY, (float(hx), float(hy), float(hz)))


def l_bracket(rng: np.random.Generator, s: float = 1.0) -> list[Obstacle]:
    """A base plate with an upright plate along one edge (an L seen from the side)."""
    length, width, height = s * rng.uniform([0.08, 0.05, 0.08], [0.18, 0.15, 0.25])
    t = s * rng.uniform(0.012, 0.03)
    return [_box(0, 0, t, length, width, t), _box(-length + t, 0, height, t, width, height)]


def arch(rng: np.random.Generator, s: float = 1.0) -> list[Obstacle]:
    """Two pillars bridged by a beam, with a free gap underneath."""
    span, depth, height = s * rng.uniform([0.06, 0.03, 0.08], [0.16, 0.1, 0.25])
    t = s * rng.uniform(0.015, 0.035)
    parts: list[Obstacle] = []
    if rng.random() < 0.5:
        parts += [_box(x, 0, height, t, depth, height) for x in (-span, span)]
    else:
        r = min(t, depth)
        parts += [Cylinder((float(x), 0.0, float(height)), _IDENTITY, float(r), float(height)) for x in (-span, span)]
    parts.append(_box(0, 0, 2 * height + t, span + t, depth, t))
    return parts


def shelf(rng: np.random.Generator, s: float = 1.0) -> list[Obstacle]:
    """Two side panels with two or three boards between them (a small open bookshelf)."""
    width, depth, height = s * rng.uniform([0.08, 0.06, 0.12], [0.18, 0.12, 0.22])
    t = s * rng.uniform(0.01, 0.02)
    parts: list[Obstacle] = [_box(x, 0, height, t, depth, height) for x in (-width, width)]
    for z in np.linspace(t, 2 * height - t, int(rng.integers(2, 4))):
        parts.append(_box(0, 0, z, width - t, depth, t))
    return parts


def ring(rng: np.random.Generator, s: float = 1.0) -> list[Obstacle]:
    """A torus approximated by 8-12 capsules on a circle, standing, lying or tilted."""
    big = s * rng.uniform(0.06, 0.15)
    small = s * rng.uniform(0.012, 0.03)
    n = int(rng.integers(8, 13))
    ang = np.arange(n) * 2 * np.pi / n
    half = big * np.sin(np.pi / n)
    tilt = Rotation.from_euler("x", rng.choice([0.0, np.pi / 2, rng.uniform(0.3, 1.2)]))
    parts: list[Obstacle] = []
    for a in ang:
        mid = np.array([big * np.cos(a + np.pi / n), big * np.sin(a + np.pi / n), 0.0]) * np.cos(np.pi / n)
        # capsule axis (local z) along the tangent of the circle
        rot = tilt * Rotation.from_euler("ZX", [a + np.pi / n, -np.pi / 2])
        parts.append(
            Capsule(
                vec3(tilt.apply(mid)),
                quat_xyzw(rot.as_quat()),
                float(small),
                float(half),
            )
        )
    return parts


def table(rng: np.random.Generator, s: float = 1.0) -> list[Obstacle]:
    """A small table or stool: a top on four legs, free space underneath."""
    hx, hy, height = s * rng.uniform([0.06, 0.06, 0.06], [0.15, 0.15, 0.18])
    t = s * rng.uniform(0.01, 0.025)
    r = s * rng.uniform(0.008, 0.02)
    legs: list[Obstacle] = [
        Cylinder((float(x), float(y), float(height)), _IDENTITY, float(r), float(height))
        for x in (-hx + r, hx - r)
        for y in (-hy + r, hy - r)
    ]
    return [*legs, _box(0, 0, 2 * height + t, hx, hy, t)]


HELDOUT_SHAPES = {
    "l_bracket": l_bracket,
    "arch": arch,
    "shelf": shelf,
    "ring": ring,
    "table": table,
}

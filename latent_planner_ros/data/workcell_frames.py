"""Furniture builders for the workcell families made of bars and walls: cages and walls with pillars.

Same local frame as workcell_furniture.py: the side the arm comes from faces -x with its front plane at x = 0,
centred on y = 0, standing on the table top z = 0. Lengths in metres.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from latent_planner_ros.data.obstacles import Box, Cylinder, Obstacle, quat_xyzw, vec3
from latent_planner_ros.data.workcell_furniture import MAX_HEIGHT, slab
from latent_planner_ros.data.workcell_regions import Furniture, Region, Surface, box_region, surface

_FORWARD = (1.0, 0.0, 0.0)
_FRONT = (-1.0, 0.0, 0.0)


def bar(a, b, radius: float, square: bool) -> Obstacle:
    """A straight bar from point a (3,) to b (3,) [m]: a round rod (cylinder) or a square tube (box)."""
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    d = b - a
    length = float(np.linalg.norm(d))
    rot, _ = Rotation.align_vectors([d / length], [[0.0, 0.0, 1.0]])
    q = quat_xyzw(rot.as_quat())
    c = vec3((a + b) / 2)
    if square:
        return Box(c, q, (radius, radius, length / 2))
    return Cylinder(c, q, radius, length / 2)


def _bar_surface(a, b, radius: float) -> Surface:
    """The patch of a bar a -> b (3,) [m] that faces -x (the arm's side), spanning 80 % of its length."""
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    return surface((a + b) / 2 - (radius, 0.0, 0.0), _FRONT, 0.4 * (b - a), kind="bar")


def cage(rng: np.random.Generator, heldout: bool = False) -> Furniture:
    """A frame of thin bars: a rack beside the robot or a fence in front of it (with wings around it).

    Bars are rods or square tubes 1-3 cm thick; every window is at least 25 cm wide so the arm can pass.
    Rack: 4 posts and the rails of its top and bottom rectangles, 0.3-0.5 m deep; its inside is a region
    entered through the open front. Fence: posts every 25-45 cm along 0.8-1.4 m, rails at 2-3 heights, half the
    time with side wings bent back towards the robot; its windows are regions (reaching through a gap).
    Held out: bars 3.2-4.4 cm thick and a diagonal brace across the rack's sides or a fence window (that window
    is then no region).
    """
    radius = rng.uniform(0.016, 0.022) if heldout else rng.uniform(0.005, 0.015)
    square = bool(rng.random() < 0.4)
    parts: list[Obstacle] = []
    surfaces: list[Surface] = []
    regions: list[Region] = []

    def add(a, b) -> None:
        parts.append(bar(a, b, radius, square))
        surfaces.append(_bar_surface(a, b, radius))

    m = radius + 0.02  # regions keep this far [m] from bar axes
    if rng.random() < 0.5:  # rack
        lx, ly, lz = rng.uniform([0.3, 0.3, 0.3], [0.5, 0.6, 0.7])
        z0 = min(rng.uniform(0.0, 0.3), MAX_HEIGHT - lz - radius)
        corners = [(x, y) for x in (radius, lx - radius) for y in (-ly / 2 + radius, ly / 2 - radius)]
        for x, y in corners:
            add((x, y, 0.0), (x, y, z0 + lz))
        for z in (z0, z0 + lz):
            for (xa, ya), (xb, yb) in ((corners[0], corners[1]), (corners[2], corners[3])):
                add((xa, ya, z), (xb, yb, z))
            for (xa, ya), (xb, yb) in ((corners[0], corners[2]), (corners[1], corners[3])):
                add((xa, ya, z), (xb, yb, z))
        if heldout:
            (x0, y0), (x1, _) = corners[0], corners[2]
            for y in (y0, -y0):
                add((x0, y, z0), (x1, y, z0 + lz))
        regions.append(box_region((0.0, -ly / 2 + m, z0 + m), (lx - m, ly / 2 - m, z0 + lz - m), _FORWARD, "window"))
        return Furniture("cage", tuple(parts), tuple(regions), tuple(surfaces), _FRONT)
    length, height = rng.uniform(0.8, 1.4), rng.uniform(0.6, 1.2)
    n_gaps = max(2, int(length / rng.uniform(0.25, 0.45)))
    ys = np.linspace(-length / 2, length / 2, n_gaps + 1)
    rails = np.sort(rng.uniform(0.15, height - 0.15, int(rng.integers(1, 3))))
    if len(rails) == 2 and rails[1] - rails[0] < 0.25:
        rails = rails[:1]
    zs = np.concatenate([rails, [height]])
    for y in ys:
        add((0.0, y, 0.0), (0.0, y, height))
    for z in zs:
        add((0.0, ys[0], z), (0.0, ys[-1], z))
    braced = int(rng.integers(n_gaps)) if heldout else -1
    for i in range(n_gaps):
        z_lo = 0.0
        for z_hi in zs:
            if i == braced and z_lo == 0.0:
                add((0.0, ys[i], z_lo), (0.0, ys[i + 1], z_hi))
            elif z_hi - z_lo > 2 * m + 0.1:
                lo, hi = (-0.03, ys[i] + m, z_lo + m), (0.03, ys[i + 1] - m, z_hi - m)
                regions.append(box_region(lo, hi, _FORWARD, "window"))
            z_lo = z_hi
    if rng.random() < 0.5:  # wings bent back towards the robot, around its base
        back = rng.uniform(0.3, 0.6)
        for y in (ys[0], ys[-1]):
            add((-back, y, 0.0), (-back, y, height))
            for z in zs:
                add((-back, y, z), (0.0, y, z))
    return Furniture("cage", tuple(parts), tuple(regions), tuple(surfaces), _FRONT)


def wall(rng: np.random.Generator, heldout: bool = False) -> Furniture:
    """A wall with 2-3 pillars standing in front of it; two of them leave a 15-30 cm gap (a region).

    Train: one straight wall 3-12 cm thick, 0.6-1.4 m long, 0.5-1.25 m high; round pillars (radius 3-8 cm).
    Held out: an L-shaped corner (a second wall at a right angle, coming 0.3-0.6 m towards the robot) and
    square pillars turned by a random yaw.
    """
    t, length = rng.uniform(0.03, 0.12), rng.uniform(0.6, 1.4)
    height = rng.uniform(0.5, MAX_HEIGHT)
    parts: list[Obstacle] = [slab((0.0, -length / 2, 0.0), (t, length / 2, height))]
    surfaces = [surface((0.0, 0.0, height / 2), _FRONT, (0.0, 0.4 * length, 0.0), (0.0, 0.0, 0.4 * height))]
    if heldout:
        reach = rng.uniform(0.3, 0.6)
        side = float(rng.choice([-1.0, 1.0])) * length / 2
        parts.append(slab((-reach, side - t / 2, 0.0), (0.0, side + t / 2, height)))
        surfaces.append(surface((-reach / 2, side - np.sign(side) * t / 2, height / 2), (0.0, -np.sign(side), 0.0),
                                (0.4 * reach, 0.0, 0.0), (0.0, 0.0, 0.4 * height)))  # fmt: skip
    regions: list[Region] = []
    n = int(rng.integers(2, 4))
    radii = rng.uniform(0.03, 0.08, n)
    x = -rng.uniform(0.12, 0.35)
    gaps = rng.uniform(0.15, 0.3, n)
    span = float(2 * radii.sum() + gaps[:-1].sum())  # of the pillar row along y [m]
    a, b = -length / 2, length / 2  # the pillar row keeps 5 cm off the side wall (and may overhang the other end)
    if heldout:
        a, b = (a, side - t / 2 - 0.09) if side > 0 else (side + t / 2 + 0.09, b)  # 4 cm for turned squares
    slack = rng.uniform(0.0, max(b - a - span, 0.0))
    y = (b - span - slack if heldout and side > 0 else a + slack) + radii[0]
    heights = rng.uniform(0.5, MAX_HEIGHT, n)
    for k in range(n):
        h, r = float(heights[k]), float(radii[k])
        if heldout:
            q = Rotation.from_euler("z", rng.uniform(0, np.pi / 2)).as_quat()
            parts.append(Box((x, float(y), h / 2), quat_xyzw(q), (r, r, h / 2)))
        else:
            parts.append(Cylinder((x, float(y), h / 2), (0.0, 0.0, 0.0, 1.0), r, h / 2))
        surfaces.append(surface((x - r * np.sqrt(2), y, h / 2), _FRONT, v=(0.0, 0.0, 0.4 * h), kind="bar"))
        if k + 1 < n:
            y_next = y + r + gaps[k] + radii[k + 1]
            r_diag = np.sqrt(2) if heldout else 1.0
            lo = (x - 0.03, y + r * r_diag + 0.02, 0.1)
            hi = (x + 0.03, y_next - radii[k + 1] * r_diag - 0.02, min(h, heights[k + 1], 0.9) - 0.05)
            if hi[1] - lo[1] > 0.05:
                regions.append(box_region(lo, hi, _FORWARD, "gap"))
            y = y_next
    return Furniture("wall", tuple(parts), tuple(regions), tuple(surfaces), _FRONT)

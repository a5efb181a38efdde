"""Furniture builders for the workcell families: bookshelves, bins and shelves with objects under them.

Every builder takes a Generator and `heldout` (use the held-out variants, see workcell_generator.py) and returns
a `Furniture` in its local frame: the opening faces -x (`front` = (-1, 0, 0)) with its front plane at x = 0,
the body extends towards +x, it is centred on y = 0 and stands on the table top z = 0. Lengths in metres.
"""

from __future__ import annotations

import numpy as np

from latent_planner_ros.data.obstacles import Box, Cylinder, Obstacle, vec3
from latent_planner_ros.data.workcell_regions import Furniture, Region, Surface, box_region, surface

MAX_HEIGHT = 1.25
"""highest point [m] of any furniture (the arm reaches about 1.19 m above its base)"""

_IDENTITY = (0.0, 0.0, 0.0, 1.0)
_FORWARD = (1.0, 0.0, 0.0)
_DOWN = (0.0, 0.0, -1.0)
_FRONT = (-1.0, 0.0, 0.0)
_UP = (0.0, 0.0, 1.0)


def slab(lo, hi) -> Box:
    """An axis-aligned box between the corners lo (3,) and hi (3,) [m]."""
    lo, hi = np.asarray(lo, dtype=float), np.asarray(hi, dtype=float)
    c, h = (lo + hi) / 2, (hi - lo) / 2
    return Box(vec3(c), _IDENTITY, vec3(h))


def _thicknesses(rng: np.random.Generator, heldout: bool) -> tuple[float, float]:
    """(board, wall) thickness [m]: both thin (1-2 cm) or both thick (3-5 cm); held out: one of each."""
    thin, thick = rng.uniform(0.01, 0.02), rng.uniform(0.03, 0.05)
    if heldout:
        return (thin, thick) if rng.random() < 0.5 else (thick, thin)
    t = thin if rng.random() < 0.5 else thick
    return t, float(t * rng.uniform(0.9, 1.1))


def bookshelf(rng: np.random.Generator, heldout: bool = False) -> Furniture:
    """Boards between two side walls, with a back panel, on the table or raised on its side walls.

    Train: 2-4 boards, slots 18-32 cm high, boards and walls of one thickness class (thin 1-2 cm or thick 3-5 cm),
    0.45-0.75 m wide. Held out: a thin/thick mix of boards and walls, and half the time 5 boards with 15-20 cm
    slots and width 0.8-0.9 m.
    """
    t_board, t_wall = _thicknesses(rng, heldout)
    depth = rng.uniform(0.25, 0.4)
    many = heldout and rng.random() < 0.5
    width = rng.uniform(0.8, 0.9) if many else rng.uniform(0.45, 0.75)
    n_boards = 5 if many else int(rng.integers(2, 5))
    slots = rng.uniform(0.15, 0.2, n_boards - 1) if many else rng.uniform(0.18, 0.32, n_boards - 1)
    stack = float(slots.sum() + n_boards * t_board)
    z0 = min(rng.uniform(0.0, 0.4), MAX_HEIGHT - stack)
    if z0 < 0:
        slots *= (MAX_HEIGHT - n_boards * t_board) / slots.sum()
        z0 = 0.0
    inner = width / 2 - t_wall
    back = depth - t_wall
    parts: list[Obstacle] = []
    regions: list[Region] = []
    surfaces: list[Surface] = []
    z = z0
    for k in range(n_boards):
        parts.append(slab((0.0, -inner, z), (back, inner, z + t_board)))
        surfaces.append(surface((0.0, 0.0, z + t_board / 2), _FRONT, (0.0, 0.8 * inner, 0.0), kind="edge"))
        if k < n_boards - 1:
            lo, hi = z + t_board, z + t_board + slots[k]
            regions.append(box_region((0.0, -inner, lo), (back, inner, hi), _FORWARD, "slot"))
        z += t_board + (slots[k] if k < n_boards - 1 else 0.0)
    top = z
    parts += [slab((0.0, -width / 2, 0.0), (depth, -inner, top)), slab((0.0, inner, 0.0), (depth, width / 2, top))]
    parts.append(slab((back, -inner, z0), (depth, inner, top)))
    if top < 1.0:
        surfaces.append(surface((depth / 2, 0.0, top), _UP, (0.35 * depth, 0.0, 0.0), (0.0, 0.7 * inner, 0.0), "face"))
    return Furniture("bookshelf", tuple(parts), tuple(regions), tuple(surfaces), _FRONT)


def bin_(rng: np.random.Generator, heldout: bool = False) -> Furniture:
    """An open box (floor and 4 walls) on the table or on a pedestal, sometimes split by a divider.

    Train: walls 10-20 cm high, one divider with probability 0.35. Held out: walls 21-27 cm high and a cross
    divider (4 compartments) or two parallel dividers (3 compartments).
    """
    lx, ly = rng.uniform(0.25, 0.45), rng.uniform(0.25, 0.5)
    h = rng.uniform(0.21, 0.27) if heldout else rng.uniform(0.1, 0.2)
    t, tf = rng.uniform(0.008, 0.025), rng.uniform(0.01, 0.03)
    z0 = rng.uniform(0.1, 0.35) if rng.random() < 0.4 else 0.0
    parts: list[Obstacle] = []
    if z0 > 0:
        s = rng.uniform(0.5, 0.9)
        parts.append(slab((lx * (1 - s) / 2, -ly * s / 2, 0.0), (lx * (1 + s) / 2, ly * s / 2, z0)))
    floor, rim = z0 + tf, z0 + tf + h
    parts.append(slab((0.0, -ly / 2, z0), (lx, ly / 2, floor)))
    parts += [slab((0.0, -ly / 2, floor), (t, ly / 2, rim)), slab((lx - t, -ly / 2, floor), (lx, ly / 2, rim))]
    parts += [
        slab((t, -ly / 2, floor), (lx - t, -ly / 2 + t, rim)),
        slab((t, ly / 2 - t, floor), (lx - t, ly / 2, rim)),
    ]
    xs, ys = [t, lx - t], [-ly / 2 + t, ly / 2 - t]  # compartment bounds
    if heldout:
        if rng.random() < 0.5:
            xs, ys = [t, lx / 2 - t / 2, lx / 2 + t / 2, lx - t], [ys[0], -t / 2, t / 2, ys[1]]
        else:
            c = ly / 6
            ys = [ys[0], -c - t / 2, -c + t / 2, c - t / 2, c + t / 2, ys[1]]
    elif rng.random() < 0.35:
        if rng.random() < 0.5:
            xs = [t, lx / 2 - t / 2, lx / 2 + t / 2, lx - t]
        else:
            ys = [ys[0], -t / 2, t / 2, ys[1]]
    for i in range(1, len(xs) - 1, 2):
        parts.append(slab((xs[i], ys[0], floor), (xs[i + 1], ys[-1], rim - 0.01)))
    for j in range(1, len(ys) - 1, 2):
        parts.append(slab((xs[0], ys[j], floor), (xs[-1], ys[j + 1], rim - 0.01)))
    regions = tuple(
        box_region((xs[i], ys[j], floor), (xs[i + 1], ys[j + 1], rim), _DOWN, "bin")
        for i in range(0, len(xs), 2)
        for j in range(0, len(ys), 2)
    )
    surfaces = (
        surface((t / 2, 0.0, rim), _UP, (0.0, 0.4 * ly, 0.0), kind="rim"),
        surface((lx - t / 2, 0.0, rim), _UP, (0.0, 0.4 * ly, 0.0), kind="rim"),
        surface((lx / 2, -ly / 2 + t / 2, rim), _UP, (0.4 * lx, 0.0, 0.0), kind="rim"),
        surface((lx / 2, ly / 2 - t / 2, rim), _UP, (0.4 * lx, 0.0, 0.0), kind="rim"),
        surface((0.0, 0.0, (floor + rim) / 2), _FRONT, (0.0, 0.4 * ly, 0.0), (0.0, 0.0, 0.3 * h), "face"),
    )
    return Furniture("bin", tuple(parts), regions, surfaces, _FRONT)


def undershelf(rng: np.random.Generator, heldout: bool = False) -> Furniture:
    """A shelf board above the table with 1-3 small objects under it (picks under a shelf).

    Train: the board's underside 25-45 cm above the table, carried by two side panels or four legs. Held out:
    18-25 cm above the table, cantilevered from a back panel only, with a 3-6 cm lip hanging from its front edge.
    """
    width, depth = rng.uniform(0.45, 0.8), rng.uniform(0.25, 0.45)
    t = rng.uniform(0.015, 0.04)
    hz = rng.uniform(0.18, 0.25) if heldout else rng.uniform(0.25, 0.45)
    parts: list[Obstacle] = [slab((0.0, -width / 2, hz), (depth, width / 2, hz + t))]
    y_in, x_back, lip = width / 2, depth, hz  # free space under the board: |y| < y_in, x < x_back, z < lip
    if heldout:
        tb = rng.uniform(0.02, 0.04)
        lip = hz - rng.uniform(0.03, 0.06)
        parts += [
            slab((depth - tb, -width / 2, 0.0), (depth, width / 2, hz)),
            slab((0.0, -width / 2, lip), (0.02, width / 2, hz)),
        ]
        x_back = depth - tb
    elif rng.random() < 0.5:
        ts = rng.uniform(0.015, 0.04)
        parts += [
            slab((0.0, s * width / 2 - (s > 0) * ts, 0.0), (depth, s * width / 2 + (s < 0) * ts, hz)) for s in (-1, 1)
        ]
        y_in = width / 2 - ts
    else:
        leg = rng.uniform(0.015, 0.025)
        for x in (leg, depth - leg):
            for y in (-width / 2 + leg, width / 2 - leg):
                parts.append(slab((x - leg, y - leg, 0.0), (x + leg, y + leg, hz)))
        y_in = width / 2 - 2 * leg
    surfaces = [surface((depth / 2, 0.0, hz), _DOWN, (0.3 * depth, 0, 0), (0, 0.6 * y_in, 0), "underside")]
    for _ in range(int(rng.integers(1, 4))):
        r, hh = rng.uniform(0.02, 0.05), rng.uniform(0.03, min(0.12, hz / 2 - 0.03))
        x, y = rng.uniform(0.06 + r, x_back - r - 0.02), rng.uniform(-y_in + r + 0.02, y_in - r - 0.02)
        if rng.random() < 0.5:
            parts.append(Cylinder((float(x), float(y), float(hh)), _IDENTITY, float(r), float(hh)))
        else:
            parts.append(slab((x - r, y - r, 0.0), (x + r, y + r, 2 * hh)))
        surfaces.append(surface((x - r, y, hh), _FRONT, v=(0.0, 0.0, 0.6 * hh), kind="face"))
    regions = (box_region((0.0, -y_in, 0.02), (x_back, y_in, lip), _FORWARD, "under"),)
    return Furniture("undershelf", tuple(parts), regions, tuple(surfaces), _FRONT)

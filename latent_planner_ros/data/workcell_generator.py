"""Procedural workcell scenes: furniture around the arm (shelves, bins, cages, overhangs, walls).

Families (WORKCELL_FAMILIES), each one piece of furniture built from box, cylinder and capsule primitives:

- "bookshelf": 2-4 boards between side walls, with a back panel (workcell_furniture.bookshelf);
- "bin": an open box on the table or on a pedestal, sometimes with a divider (workcell_furniture.bin_);
- "cage": a rack or a fence of 1-3 cm bars with gaps the arm can pass (workcell_frames.cage);
- "undershelf": a board above the table with objects under it (workcell_furniture.undershelf);
- "wall": a wall with pillars in front of it (workcell_frames.wall);
- "mixed": one piece of the five above plus 2-5 tabletop objects of data/scene_generator's shape families.

A piece stands anywhere around the base: its front (opening) plane at 0.3-0.7 m from the base axis at any
azimuth, facing the base within +-20 deg; every obstacle lies within z in [-0.05, 1.25] m and |x|, |y| <= 1 m
(the planning clouds' crop box), and keeps BASE_CLEARANCE + BASE_RADIUS (0.305 m) from the base axis.

Train / held-out split (`split`): besides different base seeds (the set generator's business), the held-out
split uses shapes and poses the train split never makes:

- every piece: its opening turned 25-45 deg away from facing the base (train: within +-20 deg);
- bookshelf: boards and walls of different thickness classes (thin 1-2 cm with thick 3-5 cm), and half the
  time 5 boards with 15-20 cm slots, 0.8-0.9 m wide (train: 2-4 boards, 18-32 cm slots, 0.45-0.75 m wide);
- bin: walls 21-27 cm high (train 10-20 cm) and a cross divider or two parallel dividers (train: at most one);
- cage: bars 3.2-4.4 cm thick (train 1-3 cm) and diagonal braces;
- undershelf: the board 18-25 cm above the table (train 25-45 cm), cantilevered from a back panel, with a
  front lip;
- wall: an L-shaped corner and square, yawed pillars (train: a straight wall, round pillars);
- mixed: the held-out piece plus objects of the held-out shape family (non-convex composites).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import coal
import numpy as np
from scipy.spatial.transform import Rotation

from latent_planner_ros.data.obstacle_geometry import coal_geometry, triangle_mesh
from latent_planner_ros.data.obstacles import Obstacle
from latent_planner_ros.data.scene import Scene
from latent_planner_ros.data.scene_generator import FAMILIES, SceneGeneratorConfig, _footprint_radius, _rest
from latent_planner_ros.data.workcell_frames import cage, wall
from latent_planner_ros.data.workcell_furniture import bin_, bookshelf, undershelf
from latent_planner_ros.data.workcell_regions import Furniture, Region, Surface

FURNITURE: dict[str, Callable[[np.random.Generator, bool], Furniture]] = {
    "bookshelf": bookshelf,
    "bin": bin_,
    "cage": cage,
    "undershelf": undershelf,
    "wall": wall,
}
"""Builders of one piece of furniture in its local frame, by family."""

WORKCELL_FAMILIES: tuple[str, ...] = (*FURNITURE, "mixed")
"""Names of the workcell scene families."""

SPLITS = ("train", "heldout")

BASE_RADIUS = 0.155
"""largest horizontal distance [m] of the Panda base (panda_link0) from its axis"""
BASE_CLEARANCE = 0.15
"""no obstacle comes within BASE_RADIUS + this [m] of the base axis (horizontally)"""
REACH_Z = (-0.05, 1.25)
"""heights [m] every obstacle lies within"""
REACH_XY = 1.0
"""largest |x| and |y| [m] of any obstacle point (the planning clouds' crop box, sim_bridge/camera_config.py)"""
SHOULDER = np.array([0.0, 0.0, 0.333])
"""the arm's shoulder (joint 2 axis) [m]; goals lie within REACH of it"""
REACH = 0.8
"""a piece is kept only if one of its regions or surfaces has its centre within this distance [m] of SHOULDER"""

FRONT_DISTANCE = {
    "bookshelf": (0.35, 0.65),
    "bin": (0.3, 0.6),
    "cage": (0.35, 0.65),
    "undershelf": (0.3, 0.6),
    "wall": (0.35, 0.7),
}
"""range of the horizontal distance [m] of a piece's front centre from the base axis, by family"""
TRAIN_YAW_DEG = 20.0
"""train split: the opening faces the base within +- this [deg]"""
HELDOUT_YAW_DEG = (25.0, 45.0)
"""held-out split: the opening is turned this far [deg] (either way) from facing the base"""


@dataclass(frozen=True)
class Workcell:
    """A workcell scene and the furniture in it (its goal regions and surfaces); `split` is "train" or "heldout"."""

    scene: Scene
    furniture: tuple[Furniture, ...]
    split: str

    @property
    def regions(self) -> tuple[Region, ...]:
        return tuple(r for f in self.furniture for r in f.regions)

    @property
    def surfaces(self) -> tuple[Surface, ...]:
        return tuple(s for f in self.furniture for s in f.surfaces)


def _keep_out() -> tuple[coal.CollisionGeometry, coal.Transform3s]:
    r = BASE_RADIUS + BASE_CLEARANCE
    return coal.Cylinder(r, 3.0), coal.Transform3s(np.eye(3), np.array([0.0, 0.0, 0.5]))


def keeps_clear_of_base(obstacles: Sequence[Obstacle]) -> bool:
    """Whether no obstacle enters the vertical cylinder of radius BASE_RADIUS + BASE_CLEARANCE [m] about z."""
    geom, tf = _keep_out()
    request, result = coal.CollisionRequest(), coal.CollisionResult()
    for o in obstacles:
        g, t = coal_geometry(o)
        result.clear()
        if coal.collide(geom, tf, g, t, request, result):
            return False
    return True


def within_reach_bounds(obstacles: Sequence[Obstacle]) -> bool:
    """Whether every obstacle lies within REACH_Z [m] and |x|, |y| <= REACH_XY [m] (tessellated)."""
    for o in obstacles:
        v = triangle_mesh(o)[0]
        if v[:, 2].min() < REACH_Z[0] - 1e-9 or v[:, 2].max() > REACH_Z[1] + 1e-9:
            return False
        if np.abs(v[:, :2]).max() > REACH_XY + 1e-9:
            return False
    return True


def min_distance(a: Sequence[Obstacle], b: Sequence[Obstacle]) -> float:
    """Smallest distance [m] between two groups of obstacles (negative or zero when they touch)."""
    request, result = coal.DistanceRequest(), coal.DistanceResult()
    best = math.inf
    geoms_b = [coal_geometry(o) for o in b]
    for o in a:
        ga, ta = coal_geometry(o)
        for gb, tb in geoms_b:
            result.clear()
            best = min(best, coal.distance(ga, ta, gb, tb, request, result))
    return best


def _reachable(piece: Furniture) -> bool:
    centres = [r.centre for r in piece.regions] + [s.centre for s in piece.surfaces]
    return any(np.linalg.norm(np.asarray(c) - SHOULDER) < REACH for c in centres)


def place(rng: np.random.Generator, piece: Furniture, split: str = "train", tries: int = 60) -> Furniture | None:
    """The piece (local frame) put at a random azimuth around the base, or None if no pose fits the bounds."""
    lo, hi = FRONT_DISTANCE[piece.family]
    for _ in range(tries):
        phi = rng.uniform(-math.pi, math.pi)
        if split == "heldout":
            turn = math.radians(rng.uniform(*HELDOUT_YAW_DEG)) * rng.choice([-1.0, 1.0])
        else:
            turn = math.radians(rng.uniform(-TRAIN_YAW_DEG, TRAIN_YAW_DEG))
        r = rng.uniform(lo, hi)
        rot = Rotation.from_euler("z", phi + turn).as_matrix()
        placed = piece.moved(rot, np.array([r * math.cos(phi), r * math.sin(phi), 0.0]))
        if within_reach_bounds(placed.parts) and keeps_clear_of_base(placed.parts) and _reachable(placed):
            return placed
    return None


def _tabletop_objects(rng: np.random.Generator, split: str, avoid: Sequence[Obstacle]) -> list[list[Obstacle]]:
    """2-5 objects of the split's tabletop shape family on the table, 3 cm clear of `avoid` and of the base."""
    cfg = SceneGeneratorConfig()
    shapes = FAMILIES[split]
    names = sorted(shapes)
    out: list[list[Obstacle]] = []
    for _ in range(int(rng.integers(2, 6))):
        parts = shapes[names[int(rng.integers(len(names)))]](rng, float(rng.uniform(*cfg.scale_range)))
        rot = Rotation.from_euler("z", rng.uniform(-math.pi, math.pi)).as_matrix()
        lift = rng.uniform(*cfg.lift_range) if rng.random() < cfg.lift_prob else -rng.uniform(*cfg.sink_range)
        for _ in range(20):
            phi, r = rng.uniform(-math.pi, math.pi), rng.uniform(0.3, 0.8)
            xy = r * np.array([math.cos(phi), math.sin(phi)])
            if r - _footprint_radius(parts) < BASE_RADIUS + BASE_CLEARANCE:
                continue
            placed = _rest(parts, rot, xy, lift)
            if keeps_clear_of_base(placed) and min_distance(placed, [*avoid, *sum(out, [])]) > 0.03:
                out.append(placed)
                break
    return out


def generate_workcell_layout(rng: np.random.Generator, family: str, seed: int = -1, split: str = "train") -> Workcell:
    """One random workcell of the family (see the module docstring); `seed` is only recorded in the scene."""
    if family not in WORKCELL_FAMILIES:
        raise ValueError(f"unknown workcell family {family!r}; choose one of {WORKCELL_FAMILIES}")
    if split not in SPLITS:
        raise ValueError(f"unknown split {split!r}; choose one of {SPLITS}")
    heldout = split == "heldout"
    kind = family if family != "mixed" else str(rng.choice(list(FURNITURE)))
    for _ in range(100):
        piece = place(rng, FURNITURE[kind](rng, heldout), split)
        if piece is not None:
            break
    else:
        raise RuntimeError(f"no {kind} fits within the arm's reach")
    obstacles, groups = list(piece.parts), [0] * len(piece.parts)
    if family == "mixed":
        for k, parts in enumerate(_tabletop_objects(rng, split, piece.parts)):
            obstacles += parts
            groups += [k + 1] * len(parts)
    scene = Scene(obstacles=tuple(obstacles), family=family, seed=seed, groups=tuple(groups))
    return Workcell(scene, (piece,), split)


def generate_workcell(rng: np.random.Generator, family: str, seed: int = -1, split: str = "train") -> Scene:
    """The scene of `generate_workcell_layout` (same draws from rng)."""
    return generate_workcell_layout(rng, family, seed, split).scene

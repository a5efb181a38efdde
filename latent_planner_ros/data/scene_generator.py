"""Procedural tabletop scenes: 4-8 objects at random poses and scales within the arm's reach."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation

from latent_planner_ros.data.composites import HELDOUT_SHAPES
from latent_planner_ros.data.obstacle_geometry import triangle_mesh
from latent_planner_ros.data.obstacles import Obstacle, transformed
from latent_planner_ros.data.scene import Scene
from latent_planner_ros.data.shapes import TRAIN_SHAPES

FAMILIES = {"train": TRAIN_SHAPES, "heldout": HELDOUT_SHAPES}
"""Object families: "train" (convex primitives and hulls) and "heldout" (non-convex composites)."""


@dataclass(frozen=True)
class SceneGeneratorConfig:
    """Ranges of the procedural scenes (lengths in metres, `world` frame, table top at z = 0)."""

    n_objects: tuple[int, int] = (4, 8)
    """inclusive range of the number of objects"""
    x_range: tuple[float, float] = (0.2, 0.8)
    """range of object centres along x [m]"""
    y_range: tuple[float, float] = (-0.5, 0.5)
    """range of object centres along y [m]"""
    scale_range: tuple[float, float] = (0.7, 1.3)
    """uniform size factor applied to each object's nominal size range"""
    base_clearance: float = 0.15
    """no object comes within this horizontal distance [m] of the robot's base axis (plus its radius)"""
    tipped_prob: float = 0.25
    """probability that an object gets a random 3D orientation instead of a random yaw"""
    lift_prob: float = 0.2
    """probability that an object floats above the table (a shelf or a hand-held object)"""
    lift_range: tuple[float, float] = (0.03, 0.3)
    """height above the table [m] of a floating object's lowest point"""
    sink_range: tuple[float, float] = (0.0, 0.01)
    """how deep [m] a resting object may sink into the table (contact rather than a gap)"""


def _rest(parts: list[Obstacle], rotation: np.ndarray, xy: np.ndarray, lift: float) -> list[Obstacle]:
    """Rotate the parts about their local origin and put their lowest point at height `lift` above (x, y)."""
    moved = [transformed(p, rotation, np.zeros(3)) for p in parts]
    z_min = min(triangle_mesh(p)[0][:, 2].min() for p in moved)
    shift = np.array([xy[0], xy[1], lift - z_min])
    return [transformed(p, np.eye(3), shift) for p in moved]


def _footprint_radius(parts: list[Obstacle]) -> float:
    """Largest horizontal distance [m] of the parts' surfaces from the local z axis."""
    return max(float(np.linalg.norm(triangle_mesh(p)[0][:, :2], axis=1).max()) for p in parts)


def generate_scene(
    rng: np.random.Generator, family: str = "train", config: SceneGeneratorConfig | None = None, seed: int = -1
) -> Scene:
    """One random scene of the given family ("train" or "heldout"); `seed` is only recorded in the scene."""
    if family not in FAMILIES:
        raise ValueError(f"unknown scene family {family!r}; choose one of {sorted(FAMILIES)}")
    cfg = config or SceneGeneratorConfig()
    shapes = FAMILIES[family]
    names = sorted(shapes)
    n = int(rng.integers(cfg.n_objects[0], cfg.n_objects[1] + 1))
    obstacles: list[Obstacle] = []
    groups: list[int] = []
    for k in range(n):
        parts = shapes[names[int(rng.integers(len(names)))]](rng, float(rng.uniform(*cfg.scale_range)))
        if rng.random() < cfg.tipped_prob:
            rot = Rotation.random(random_state=int(rng.integers(2**31))).as_matrix()
        else:
            rot = Rotation.from_euler("z", rng.uniform(-np.pi, np.pi)).as_matrix()
        radius = _footprint_radius([transformed(p, rot, np.zeros(3)) for p in parts])
        for _ in range(50):
            xy = rng.uniform([cfg.x_range[0], cfg.y_range[0]], [cfg.x_range[1], cfg.y_range[1]])
            if np.linalg.norm(xy) - radius > cfg.base_clearance:
                break
        else:
            continue  # too big to keep clear of the base: drop the object
        lift = rng.uniform(*cfg.lift_range) if rng.random() < cfg.lift_prob else -rng.uniform(*cfg.sink_range)
        obstacles += _rest(parts, rot, xy, lift)
        groups += [k] * len(parts)
    return Scene(obstacles=tuple(obstacles), family=family, seed=seed, groups=tuple(groups))

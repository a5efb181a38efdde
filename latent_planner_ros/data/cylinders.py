"""LSPP's state-based obstacles (seed chapter 6, IV-B): upright cylinders o = (x, y, h, r) on the table.

A cylinder stands on the table plane z = 0 with its axis along world z: centre (x, y, h / 2), height h [m],
radius r [m]. Positions are sampled as in the seed: a distance L to the robot's base and an angle theta,
x = L cos(theta), y = L sin(theta).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from latent_planner_ros.data.obstacles import Cylinder
from latent_planner_ros.data.scene import Scene


@dataclass(frozen=True)
class CylinderRanges:
    """Sampling ranges of o = (x, y, h, r); every obstacle stays clear of the robot's base."""

    distance: tuple[float, float] = (0.3, 0.8)
    """L, distance of the axis to the base [m]"""
    height: tuple[float, float] = (0.1, 1.0)
    """h [m]"""
    radius: tuple[float, float] = (0.03, 0.1)
    """r [m]"""

    def sample(self, rng: np.random.Generator, n: int) -> np.ndarray:
        """n cylinders (n, 4) as (x, y, h, r)."""
        dist = rng.uniform(*self.distance, size=n)
        theta = rng.uniform(0.0, 2.0 * np.pi, size=n)
        return np.stack(
            [
                dist * np.cos(theta),
                dist * np.sin(theta),
                rng.uniform(*self.height, size=n),
                rng.uniform(*self.radius, size=n),
            ],
            axis=1,
        )

    @property
    def low(self) -> np.ndarray:
        return np.array([-self.distance[1], -self.distance[1], self.height[0], self.radius[0]])

    @property
    def high(self) -> np.ndarray:
        return np.array([self.distance[1], self.distance[1], self.height[1], self.radius[1]])


def validate_cylinders(o: np.ndarray) -> np.ndarray:
    """Check and return cylinders as a float (K, 4) array; raises ValueError naming the problem."""
    a = np.asarray(o, dtype=float)
    if a.size == 0:
        return np.zeros((0, 4))
    if a.ndim != 2 or a.shape[1] != 4:
        raise ValueError(f"cylinders must be a (K, 4) array of (x, y, h, r), got shape {a.shape}")
    if not np.all(np.isfinite(a)):
        raise ValueError("cylinders must be finite numbers")
    if np.any(a[:, 2:] <= 0):
        raise ValueError("cylinder heights and radii must be positive")
    return a


def cylinder_obstacle(o: np.ndarray) -> Cylinder:
    """The obstacle primitive of one cylinder o = (x, y, h, r)."""
    x, y, h, r = (float(v) for v in o)
    return Cylinder(position=(x, y, h / 2.0), quaternion_xyzw=(0.0, 0.0, 0.0, 1.0), radius=r, half_length=h / 2.0)


def cylinder_scene(cylinders: np.ndarray, seed: int = -1) -> Scene:
    """A scene of upright cylinders (K, 4)."""
    return Scene(tuple(cylinder_obstacle(o) for o in validate_cylinders(cylinders)), family="cylinders", seed=seed)

"""Checks of generated benchmark problems against the TRUE obstacles: obstacles grown by a clearance, and whether the
direct joint-space motion between two configurations collides. Shared by the tabletop, workcell and grasp
generators (bench/scenario_generator.py, bench/workcell_problems.py, bench/grasp_problems.py)."""

from __future__ import annotations

import numpy as np

from latent_planner_ros.data.labels import CollisionLabeler
from latent_planner_ros.data.obstacles import Box, Capsule, Cylinder, Mesh, Obstacle, Sphere


def inflated(obstacle: Obstacle, margin: float) -> Obstacle:
    """The obstacle grown by `margin` [m] (primitives exactly; meshes scaled about their centroid)."""
    if isinstance(obstacle, Box):
        return Box(obstacle.position, obstacle.quaternion_xyzw, tuple(h + margin for h in obstacle.half_extents))
    if isinstance(obstacle, Sphere):
        return Sphere(obstacle.position, obstacle.radius + margin)
    if isinstance(obstacle, Cylinder):
        return Cylinder(
            obstacle.position, obstacle.quaternion_xyzw, obstacle.radius + margin, obstacle.half_length + margin
        )
    if isinstance(obstacle, Capsule):
        return Capsule(obstacle.position, obstacle.quaternion_xyzw, obstacle.radius + margin, obstacle.half_length)
    c = obstacle.vertices.mean(0)
    r = np.linalg.norm(obstacle.vertices - c, axis=1)
    scale = (r + margin) / np.maximum(r, 1e-9)
    return Mesh(vertices=c + (obstacle.vertices - c) * scale[:, None], faces=obstacle.faces)


def direct_motion_collides(labeler: CollisionLabeler, qa: np.ndarray, qb: np.ndarray, step: float = 0.02) -> bool:
    """Whether the straight joint-space line qa -> qb (7,) [rad], checked every `step` [rad], hits an obstacle."""
    k = max(1, int(np.ceil(np.abs(qb - qa).max() / step)))
    return bool(labeler.label(qa + (qb - qa) * (np.arange(k + 1) / k)[:, None]).any())

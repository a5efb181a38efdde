"""Camera viewpoints that see into a piece of furniture (shelf slots, bin interiors, the space under a shelf).

Two or three views, placed from the piece's pose with random jitter:

1. in front of the opening, looking into a random region at its height (into a bin: from 0.4-0.7 m higher);
2. above and to one side (30-70 deg from the front direction), looking down at the middle of the regions;
3. half the time, from the other side at a lower height, looking at a random region.

A view is redrawn (up to 20 times) when its eye is below 0.15 m, within 0.4 m of the base axis below 1.5 m
(inside the robot), or when its line of sight to the target is blocked farther than 12 cm before the target.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from latent_planner_ros.data.obstacles import Capsule, Obstacle
from latent_planner_ros.data.workcell_generator import min_distance
from latent_planner_ros.data.workcell_regions import Furniture
from latent_planner_ros.robot.rotations import matrix_to_quat

_UP = np.array([0.0, 0.0, 1.0])


def _rot_z(angle: float) -> np.ndarray:
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def sees(eye: np.ndarray, target: np.ndarray, obstacles: Sequence[Obstacle], slack: float = 0.12) -> bool:
    """Whether the segment from eye (3,) to `slack` [m] before target (3,) misses every obstacle (by 1 cm)."""
    d = target - eye
    length = float(np.linalg.norm(d)) - slack
    if length <= 0.0 or not obstacles:
        return True
    z = d / np.linalg.norm(d)
    x = np.cross(z, [1.0, 0.0, 0.0]) if abs(z[0]) < 0.9 else np.cross(z, [0.0, 1.0, 0.0])
    x /= np.linalg.norm(x)
    rot = np.stack([x, np.cross(z, x), z], 1)
    centre = eye + z * length / 2
    ray = Capsule(tuple(centre.tolist()), tuple(matrix_to_quat(rot).tolist()), 0.01, length / 2)
    return min_distance([ray], obstacles) > 0.0


def _ok(eye: np.ndarray, target: np.ndarray, obstacles: Sequence[Obstacle]) -> bool:
    if eye[2] < 0.15 or (np.hypot(eye[0], eye[1]) < 0.4 and eye[2] < 1.5):
        return False
    return sees(eye, target, obstacles)


def workcell_viewpoints(
    piece: Furniture, rng: np.random.Generator, obstacles: Sequence[Obstacle] | None = None
) -> list[tuple[np.ndarray, np.ndarray]]:
    """2-3 (eye (3,), target (3,)) pairs [m] in `world` that see into the piece (see the module docstring).

    obstacles: what may block the views (default: the piece's parts).
    """
    obstacles = piece.parts if obstacles is None else obstacles
    front = np.asarray(piece.front, dtype=float)
    side = np.cross(_UP, front)
    targets = [np.asarray(r.centre) for r in piece.regions] or [np.asarray(s.centre) for s in piece.surfaces]
    focus = np.mean(targets, axis=0)
    into_bin = any(r.kind == "bin" for r in piece.regions)

    def front_view():
        t = targets[int(rng.integers(len(targets)))] + rng.uniform(-0.03, 0.03, 3)
        lift = rng.uniform(0.4, 0.7) if into_bin else rng.uniform(0.0, 0.25)
        return t + front * rng.uniform(0.9, 1.3) + side * rng.uniform(-0.2, 0.2) + _UP * lift, t

    def above_view():
        t = focus + rng.uniform(-0.03, 0.03, 3)
        d = _rot_z(math.radians(rng.uniform(30.0, 70.0)) * rng.choice([-1.0, 1.0])) @ front
        return t + d * rng.uniform(0.4, 0.7) + _UP * rng.uniform(0.7, 1.0), t

    def side_view():
        t = targets[int(rng.integers(len(targets)))] + rng.uniform(-0.03, 0.03, 3)
        d = _rot_z(math.radians(rng.uniform(40.0, 80.0)) * rng.choice([-1.0, 1.0])) @ front
        return t + d * rng.uniform(0.8, 1.2) + _UP * rng.uniform(0.3, 0.6), t

    makers = [front_view, above_view] + ([side_view] if rng.random() < 0.5 else [])
    views = []
    for make in makers:
        for _ in range(20):
            eye, target = make()
            if _ok(eye, target, obstacles):
                break
        views.append((eye, target))
    return views


def clutter_viewpoint(
    targets: Sequence[Obstacle], rng: np.random.Generator, obstacles: Sequence[Obstacle]
) -> tuple[np.ndarray, np.ndarray]:
    """An (eye (3,), target (3,)) pair [m] in `world` that sees the objects `targets` (tabletop clutter beside the
    furniture): from the default camera ranges around the centre of their bounding box, unblocked if possible."""
    from dataclasses import replace

    from latent_planner_ros.data.camera import CameraConfig, sample_camera_pose
    from latent_planner_ros.data.obstacle_geometry import triangle_mesh

    corners = np.concatenate([triangle_mesh(o)[0] for o in targets])
    centre = (corners.min(0) + corners.max(0)) / 2
    look = (float(centre[0]), float(centre[1]), float(centre[2]))
    config = replace(CameraConfig(), target=look, target_jitter=0.03)
    for _ in range(20):
        pose = sample_camera_pose(rng, config)
        eye, target = pose[:3, 3], pose[:3, 3] + pose[:3, 2]
        if _ok(eye, target, obstacles):
            break
    return eye, target

"""The ``conveyor`` generator: a belt across the workspace carrying a target object and an obstacle.

The belt runs along world y in front of the robot. A small box (the tagged target object) and a box
obstacle of random size ride on it at the same speed and keep their distance: wrapping round together at the
belt's ends (a loop) or (bounce) with the belt reversing whenever an object reaches an end.
The target pose (published on ``target_pose``) follows the target object: the end effector pointing
down, ``approach_height`` above the object's top face.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from sim_bridge.placement import check_range
from sim_bridge.scenario import MOTION_MODES, Motion, Scenario, ScenarioError, SceneObject, Target

BELT_RGBA = (0.15, 0.15, 0.17, 1.0)
TARGET_RGBA = (0.2, 0.75, 0.3, 1.0)
OBSTACLE_RGBA = (0.85, 0.3, 0.25, 1.0)
DOWN = (1.0, 0.0, 0.0, 0.0)
"""Quaternion (x, y, z, w) of the end effector pointing straight down (the ready pose's orientation)."""


@dataclass(frozen=True)
class ConveyorParams:
    """Parameters of the conveyor generator (the ``params`` of a ``generator: conveyor`` file).

    Attributes:
        speed: [m/s] belt speed along +y (negative: along -y).
        mode: "wrap" (objects leaving one end reappear at the other) or "bounce" (the belt reverses when an
            object reaches an end; all objects reverse together).
        belt_x: [m] x of the belt's centre line; belt_length, belt_width: [m]; belt_height: [m] top face z.
        target_half_extents: [m] half extents (3,) of the target box.
        approach_height: [m] height of the target pose above the target object's top face.
        obstacle_min_half_extents, obstacle_max_half_extents: [m] (3,) range of the obstacle's half extents.
        min_gap: [m] minimum free distance along the belt between target and obstacle.
    """

    speed: float = 0.05
    mode: str = "wrap"
    belt_x: float = 0.5
    belt_length: float = 1.2
    belt_width: float = 0.2
    belt_height: float = 0.05
    target_half_extents: tuple[float, float, float] = (0.025, 0.025, 0.025)
    approach_height: float = 0.1
    obstacle_min_half_extents: tuple[float, float, float] = (0.02, 0.03, 0.05)
    obstacle_max_half_extents: tuple[float, float, float] = (0.06, 0.06, 0.15)
    min_gap: float = 0.15

    def __post_init__(self) -> None:
        check_range("speed", self.speed, -1.0, 1.0)
        if self.mode not in MOTION_MODES:
            raise ScenarioError(f"mode: expected one of {MOTION_MODES}, got {self.mode!r}")
        check_range("belt_x", self.belt_x, 0.0, 1.2)
        check_range("belt_length", self.belt_length, 0.3, 3.0)
        check_range("belt_width", self.belt_width, 0.05, 1.0)
        check_range("belt_height", self.belt_height, 0.005, 0.5)
        check_range("approach_height", self.approach_height, 0.0, 0.5)
        check_range("min_gap", self.min_gap, 0.0, self.belt_length)
        for name in ("target_half_extents", "obstacle_min_half_extents", "obstacle_max_half_extents"):
            value = np.asarray(getattr(self, name), dtype=float)
            if value.shape != (3,) or not np.all(value > 0) or not np.all(value <= self.belt_length / 2):
                raise ScenarioError(f"{name}: expected 3 positive half extents [m], got {getattr(self, name)!r}")
        lo, hi = np.asarray(self.obstacle_min_half_extents), np.asarray(self.obstacle_max_half_extents)
        if np.any(lo > hi):
            raise ScenarioError("obstacle_min_half_extents: exceeds obstacle_max_half_extents")
        t = self.target_half_extents[1]
        needed = 2 * max(t, hi[1]) + 2 * (t + hi[1] + self.min_gap)  # the loop (see conveyor) holds both gaps
        if needed > self.belt_length:
            raise ScenarioError(
                f"belt_length: {self.belt_length} m cannot hold target, obstacle and min_gap on both sides "
                f"(needs {needed:.3f} m)"
            )


def _on_belt(
    p: ConveyorParams, name: str, half_extents: np.ndarray, x: float, y: float, rgba, half_loop: float, shift
) -> SceneObject:
    """A box resting on the belt at (x, y), moving with it.

    Wrap: every object's centre travels the same loop [-half_loop, half_loop) [m] (so objects keep their
    distances along the loop). Bounce: the belt reverses, so every object on it reverses at the same moment;
    `shift` (lowest, highest) [m] is the belt's travel along y from its start that keeps every object on the
    belt (see _belt_shift).
    """
    z = p.belt_height + half_extents[2]
    low, high = -half_loop, half_loop
    if p.mode == "bounce":
        low, high = y + shift[0], y + shift[1]
    motion = Motion(
        velocity=(0.0, float(p.speed), 0.0),
        lower=(x, float(low), z),
        upper=(x, float(high), z),
        mode=p.mode,
    )
    return SceneObject(
        name=name,
        type="box",
        position=(float(x), float(y), float(z)),
        half_extents=tuple(float(h) for h in half_extents),
        rgba=rgba,
        motion=motion if p.speed != 0.0 else None,
    )


def _belt_shift(length: float, placed) -> tuple[float, float]:
    """(lowest, highest) shift [m] of a reversing belt of `length` [m] from its start that keeps every object
    on it: placed = ((y, half extent along y), ...) [m] at the start. Objects keep their distances (none can
    pass through another), unlike objects reversing one by one at the ends."""
    low = max(-length / 2 + half - y for y, half in placed)
    high = min(length / 2 - half - y for y, half in placed)
    return min(low, 0.0), max(high, 0.0)


def conveyor(rng: np.random.Generator, params: ConveyorParams | None = None) -> Scenario:
    """A conveyor scene: belt, moving target object (followed by the target pose) and moving obstacle."""
    p = params or ConveyorParams()
    half_belt = p.belt_height / 2
    belt = SceneObject(
        name="belt",
        type="box",
        position=(p.belt_x, 0.0, half_belt),
        half_extents=(p.belt_width / 2, p.belt_length / 2, half_belt),
        rgba=BELT_RGBA,
    )
    target_he = np.asarray(p.target_half_extents, dtype=float)
    obstacle_he = rng.uniform(p.obstacle_min_half_extents, p.obstacle_max_half_extents)
    obstacle_he[:2] = np.minimum(obstacle_he[:2], [p.belt_width / 2, p.belt_length / 2])
    # Positions along the belt: the objects' centres share a loop [-h, h) with h = L / 2 - the larger half
    # length, so both stay on the belt and wrap round together; the obstacle keeps at least min_gap of free
    # belt from the target on both sides along that loop (validated in ConveyorParams).
    length = p.belt_length
    half_loop = length / 2 - max(target_he[1], obstacle_he[1])
    loop = 2 * half_loop
    y_target = rng.uniform(-half_loop, half_loop)
    clearance = target_he[1] + obstacle_he[1] + p.min_gap
    offset = rng.uniform(clearance, max(clearance, loop - clearance))
    y_obstacle = float((y_target + offset + half_loop) % loop - half_loop)
    x_obstacle = p.belt_x + rng.uniform(-1, 1) * max(0.0, p.belt_width / 2 - obstacle_he[0])
    shift = _belt_shift(length, ((y_target, target_he[1]), (y_obstacle, obstacle_he[1])))
    target_obj = _on_belt(p, "target", target_he, p.belt_x, y_target, TARGET_RGBA, half_loop, shift)
    obstacle = _on_belt(p, "obstacle", obstacle_he, x_obstacle, y_obstacle, OBSTACLE_RGBA, half_loop, shift)
    target = Target(position=(0.0, 0.0, float(target_he[2] + p.approach_height)), quaternion_xyzw=DOWN, object="target")
    return Scenario(
        name="conveyor",
        objects=(belt, target_obj, obstacle),
        target=target,
        description=f"belt at {p.speed} m/s ({p.mode}); obstacle half extents {np.round(obstacle_he, 3).tolist()}",
    )

"""The ``tabletop`` generator: 4-8 random objects (boxes, cylinders, spheres, capsules, convex meshes)
resting at random poses on the table in front of the robot."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation

from sim_bridge.placement import (
    check_interval,
    check_range,
    quaternion_xyzw,
    random_convex_mesh,
    resting_height,
)
from sim_bridge.scenario import SHAPES, Scenario, ScenarioError, SceneObject

PALETTE = (
    (0.85, 0.33, 0.31, 1.0),
    (0.36, 0.62, 0.86, 1.0),
    (0.95, 0.76, 0.26, 1.0),
    (0.45, 0.75, 0.45, 1.0),
    (0.67, 0.47, 0.80, 1.0),
    (0.96, 0.55, 0.24, 1.0),
)


@dataclass(frozen=True)
class TabletopParams:
    """Parameters of the tabletop generator (the ``params`` of a ``generator: tabletop`` file).

    Attributes:
        min_objects, max_objects: the object count is uniform in [min_objects, max_objects].
        x_range, y_range: [m] region of the object centres on the table.
        base_clearance: [m] minimum horizontal distance between an object and the robot base axis.
        size_range: [m] range of half sizes (half extents, radii, half lengths).
        max_height: [m] no object is taller than this (keeps the arm's ready pose free).
        types: object types to draw from.
        lying_probability: chance that a cylinder or capsule lies on its side.
        min_gap: [m] wanted horizontal gap between objects' bounding circles (relaxed if they do not fit).
    """

    min_objects: int = 4
    max_objects: int = 8
    x_range: tuple[float, float] = (0.3, 0.8)
    y_range: tuple[float, float] = (-0.5, 0.5)
    base_clearance: float = 0.2
    size_range: tuple[float, float] = (0.02, 0.08)
    max_height: float = 0.3
    types: tuple[str, ...] = ("box", "cylinder", "sphere", "capsule", "mesh")
    lying_probability: float = 0.3
    min_gap: float = 0.02

    def __post_init__(self) -> None:
        for name in ("min_objects", "max_objects"):
            value = getattr(self, name)
            if not isinstance(value, int) or isinstance(value, bool) or not 0 <= value <= 50:
                raise ScenarioError(f"{name}: expected an integer in [0, 50], got {value!r}")
        if self.min_objects > self.max_objects:
            raise ScenarioError(f"min_objects: {self.min_objects} exceeds max_objects {self.max_objects}")
        check_interval("x_range", self.x_range, -1.5, 1.5)
        check_interval("y_range", self.y_range, -1.5, 1.5)
        check_interval("size_range", self.size_range, 1e-3, 0.5)
        check_range("base_clearance", self.base_clearance, 0.0, 1.0)
        check_range("max_height", self.max_height, 2 * self.size_range[0], 2.0)
        check_range("lying_probability", self.lying_probability, 0.0, 1.0)
        check_range("min_gap", self.min_gap, 0.0, 0.5)
        bad = [t for t in self.types if t not in SHAPES]
        if not self.types or bad:
            raise ScenarioError(f"types: expected a non-empty list of {tuple(SHAPES)}, got {list(self.types)}")


def _draw_object(rng: np.random.Generator, p: TabletopParams) -> tuple[str, dict, Rotation]:
    """A random type, its size fields and its orientation."""
    kind = str(rng.choice(p.types))
    lo, hi = p.size_range
    half_height = p.max_height / 2
    if kind == "box":
        he = rng.uniform(lo, hi, size=3)
        he[2] = min(he[2], half_height)
        return kind, {"half_extents": tuple(float(x) for x in he)}, Rotation.from_euler("z", rng.uniform(0, 2 * np.pi))
    if kind == "sphere":
        return kind, {"radius": float(rng.uniform(lo, min(hi, half_height)))}, Rotation.identity()
    if kind in ("cylinder", "capsule"):
        radius = float(rng.uniform(lo, hi))
        extra = radius if kind == "capsule" else 0.0
        half_length = float(rng.uniform(lo, max(lo, min(hi * 1.5, half_height - extra))))
        yaw = Rotation.from_euler("z", rng.uniform(0, 2 * np.pi))
        lying = rng.uniform() < p.lying_probability
        return kind, {"radius": radius, "half_length": half_length}, yaw * Rotation.from_euler("x", np.pi / 2 * lying)
    semi_axes = rng.uniform(lo, hi, size=3)
    semi_axes[2] = min(semi_axes[2], half_height)
    return kind, random_convex_mesh(rng, semi_axes), Rotation.from_euler("z", rng.uniform(0, 2 * np.pi))


def tabletop(rng: np.random.Generator, params: TabletopParams | None = None) -> Scenario:
    """A random tabletop scene (deterministic for a given generator state)."""
    p = params or TabletopParams()
    count = int(rng.integers(p.min_objects, p.max_objects + 1))
    placed: list[tuple[np.ndarray, float]] = []
    objects = []
    for i in range(count):
        kind, sizes, rotation = _draw_object(rng, p)
        radius = SceneObject(name="_", type=kind, position=(0.0, 0.0, 0.0), **sizes).bounding_radius()
        best = None
        for _attempt in range(200):
            xy = np.array([rng.uniform(*p.x_range), rng.uniform(*p.y_range)])
            if np.linalg.norm(xy) - radius < p.base_clearance:
                continue
            gap = min((np.linalg.norm(xy - c) - radius - r for c, r in placed), default=np.inf)
            if best is None or gap > best[1]:
                best = (xy, gap)
            if gap >= p.min_gap:
                break
        if best is None:  # the region lies within the base clearance: no valid place at all
            raise ScenarioError(f"x_range/y_range: no point is {p.base_clearance} m away from the robot base")
        xy = best[0]
        placed.append((xy, radius))
        z = resting_height(kind, rotation.as_matrix(), sizes)
        objects.append(
            SceneObject(
                name=f"{kind}_{i}",
                type=kind,
                position=(float(xy[0]), float(xy[1]), z),
                quaternion_xyzw=quaternion_xyzw(rotation),
                rgba=PALETTE[i % len(PALETTE)],
                **sizes,
            )
        )
    return Scenario(name="tabletop", objects=tuple(objects), description=f"{count} random objects on the table")

"""Obstacle primitives in frame `world` and their JSON schema.

The schema is shared with the benchmark scenario files:

    {"type": "box", "position": [3], "quaternion_xyzw": [4], "half_extents": [3]}
    {"type": "cylinder", "position": [3], "quaternion_xyzw": [4], "radius": r, "half_length": h}
    {"type": "sphere", "position": [3], "radius": r}
    {"type": "capsule", "position": [3], "quaternion_xyzw": [4], "radius": r, "half_length": h}
    {"type": "mesh", "vertices": [[3], ...], "faces": [[3], ...]}

Lengths in metres. Cylinders and capsules have their axis along the local z axis (half_length is half the
length of the axis segment; a capsule's total length is 2 * (half_length + radius)). Mesh vertices are in
`world`; faces are vertex-index triangles with outward (counter-clockwise) winding.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from typing import Any

import numpy as np

from latent_planner_ros.robot.rotations import matrix_to_quat, quat_to_matrix

_IDENTITY_Q = (0.0, 0.0, 0.0, 1.0)

Vec3 = tuple[float, float, float]
Quat = tuple[float, float, float, float]


def vec3(v: Iterable[Any]) -> Vec3:
    """The three numbers of v (an array or sequence of 3) as floats; ValueError for another count."""
    x, y, z = (float(c) for c in v)
    return x, y, z


def quat_xyzw(v: Iterable[Any]) -> Quat:
    """The four numbers of a quaternion v (x, y, z, w) as floats; ValueError for another count."""
    x, y, z, w = (float(c) for c in v)
    return x, y, z, w


def _vec(v: Any, n: int, name: str) -> tuple[float, ...]:
    a = np.asarray(v, dtype=float).reshape(-1)
    if a.shape != (n,) or not np.all(np.isfinite(a)):
        raise ValueError(f"{name} must be {n} finite numbers, got {v!r}")
    return tuple(float(x) for x in a)


def _positive(v: Any, name: str) -> float:
    x = float(v)
    if not np.isfinite(x) or x <= 0.0:
        raise ValueError(f"{name} must be a positive number, got {v!r}")
    return x


@dataclass(frozen=True)
class Box:
    position: Vec3
    quaternion_xyzw: Quat
    half_extents: Vec3
    """half side lengths along the local x, y, z axes [m]"""


@dataclass(frozen=True)
class Cylinder:
    position: Vec3
    quaternion_xyzw: Quat
    radius: float
    half_length: float
    """half the length along the local z axis [m]"""


@dataclass(frozen=True)
class Sphere:
    position: Vec3
    radius: float


@dataclass(frozen=True)
class Capsule:
    position: Vec3
    quaternion_xyzw: Quat
    radius: float
    half_length: float
    """half the length of the axis segment (local z) [m], without the hemispherical caps"""


@dataclass(frozen=True)
class Mesh:
    vertices: np.ndarray
    """(V, 3) float64 vertex positions in `world` [m]"""
    faces: np.ndarray
    """(F, 3) int64 vertex indices per triangle"""

    def __eq__(self, other: object) -> bool:
        return (
            isinstance(other, Mesh)
            and np.array_equal(self.vertices, other.vertices)
            and np.array_equal(self.faces, other.faces)
        )

    def __hash__(self) -> int:
        return hash((self.vertices.tobytes(), self.faces.tobytes()))


Obstacle = Box | Cylinder | Sphere | Capsule | Mesh


def pose_matrix(obstacle: Obstacle) -> np.ndarray:
    """(4, 4) pose of a primitive in `world` (identity for meshes, whose vertices are already in `world`)."""
    t = np.eye(4)
    if isinstance(obstacle, Mesh):
        return t
    t[:3, 3] = obstacle.position
    if not isinstance(obstacle, Sphere):
        t[:3, :3] = quat_to_matrix(np.asarray(obstacle.quaternion_xyzw))
    return t


def bounding_sphere(obstacle: Obstacle) -> tuple[np.ndarray, float]:
    """Centre (3,) [m] and radius [m] of a sphere that contains the obstacle."""
    if isinstance(obstacle, Mesh):
        lo, hi = obstacle.vertices.min(0), obstacle.vertices.max(0)
        c = (lo + hi) / 2
        return c, float(np.linalg.norm(obstacle.vertices - c, axis=1).max())
    c = np.asarray(obstacle.position, dtype=float)
    if isinstance(obstacle, Box):
        return c, float(np.linalg.norm(obstacle.half_extents))
    if isinstance(obstacle, Sphere):
        return c, obstacle.radius
    if isinstance(obstacle, Cylinder):
        return c, float(np.hypot(obstacle.radius, obstacle.half_length))
    return c, obstacle.radius + obstacle.half_length


def distance_below(obstacle: Obstacle, points: np.ndarray) -> np.ndarray:
    """(N,) a lower bound [m] on the distance from each point (N, 3) [m] in `world` to the obstacle (0 inside):
    exact for the primitives, the distance to the bounding sphere for a mesh. A ball of radius rho about a point
    cannot touch the obstacle where rho <= the bound."""
    p = np.asarray(points, dtype=float).reshape(-1, 3)
    if isinstance(obstacle, Mesh):
        c, r = bounding_sphere(obstacle)
        return np.maximum(np.linalg.norm(p - c, axis=1) - r, 0.0)
    local = p - np.asarray(obstacle.position, dtype=float)
    if isinstance(obstacle, Sphere):
        return np.maximum(np.linalg.norm(local, axis=1) - obstacle.radius, 0.0)
    local = local @ quat_to_matrix(np.asarray(obstacle.quaternion_xyzw))  # R^T (p - c), one row per point
    if isinstance(obstacle, Box):
        return np.linalg.norm(np.maximum(np.abs(local) - np.asarray(obstacle.half_extents), 0.0), axis=1)
    along = np.abs(local[:, 2]) - obstacle.half_length
    radial = np.hypot(local[:, 0], local[:, 1])
    if isinstance(obstacle, Cylinder):
        return np.hypot(np.maximum(radial - obstacle.radius, 0.0), np.maximum(along, 0.0))
    return np.maximum(np.hypot(radial, np.maximum(along, 0.0)) - obstacle.radius, 0.0)  # capsule


def obstacle_to_dict(obstacle: Obstacle) -> dict:
    """The JSON-ready dict of an obstacle (see the module docstring)."""
    if isinstance(obstacle, Box):
        return {
            "type": "box",
            "position": list(obstacle.position),
            "quaternion_xyzw": list(obstacle.quaternion_xyzw),
            "half_extents": list(obstacle.half_extents),
        }
    if isinstance(obstacle, Sphere):
        return {"type": "sphere", "position": list(obstacle.position), "radius": obstacle.radius}
    if isinstance(obstacle, Cylinder | Capsule):
        return {
            "type": "cylinder" if isinstance(obstacle, Cylinder) else "capsule",
            "position": list(obstacle.position),
            "quaternion_xyzw": list(obstacle.quaternion_xyzw),
            "radius": obstacle.radius,
            "half_length": obstacle.half_length,
        }
    if isinstance(obstacle, Mesh):
        return {"type": "mesh", "vertices": obstacle.vertices.tolist(), "faces": obstacle.faces.tolist()}
    raise TypeError(f"not an obstacle: {obstacle!r}")


def obstacle_from_dict(d: dict) -> Obstacle:
    """Parse one obstacle dict; raises ValueError naming the problem."""
    if not isinstance(d, dict) or "type" not in d:
        raise ValueError(f"an obstacle must be a dict with a 'type', got {d!r}")
    kind = d["type"]
    try:
        if kind == "mesh":
            v = np.asarray(d["vertices"], dtype=float)
            f = np.asarray(d["faces"], dtype=np.int64)
            if v.ndim != 2 or v.shape[1] != 3 or len(v) < 4 or not np.all(np.isfinite(v)):
                raise ValueError("mesh 'vertices' must be a list of at least 4 finite [x, y, z]")
            if f.ndim != 2 or f.shape[1] != 3 or len(f) < 4 or f.min() < 0 or f.max() >= len(v):
                raise ValueError("mesh 'faces' must be a list of at least 4 [i, j, k] vertex indices")
            return Mesh(vertices=v, faces=f)
        pos = vec3(_vec(d["position"], 3, "position"))
        if kind == "sphere":
            return Sphere(pos, _positive(d["radius"], "radius"))
        quat = quat_xyzw(_vec(d.get("quaternion_xyzw", _IDENTITY_Q), 4, "quaternion_xyzw"))
        norm = float(np.linalg.norm(quat))
        if norm < 1e-9:
            raise ValueError("quaternion_xyzw has zero norm")
        if abs(norm - 1.0) > 1e-9:
            quat = quat_xyzw(x / norm for x in quat)
        if kind == "box":
            he = vec3(_vec(d["half_extents"], 3, "half_extents"))
            if min(he) <= 0:
                raise ValueError(f"half_extents must be positive, got {he}")
            return Box(pos, quat, he)
        if kind in ("cylinder", "capsule"):
            cls = Cylinder if kind == "cylinder" else Capsule
            return cls(pos, quat, _positive(d["radius"], "radius"), _positive(d["half_length"], "half_length"))
    except KeyError as e:
        raise ValueError(f"{kind} obstacle lacks the field {e.args[0]!r}") from e
    raise ValueError(f"unknown obstacle type {kind!r} (box, cylinder, sphere, capsule, mesh)")


def transformed(obstacle: Obstacle, rotation: np.ndarray, translation: np.ndarray) -> Obstacle:
    """The obstacle moved by the rigid transform x -> rotation (3, 3) @ x + translation (3,) [m]."""
    rot = np.asarray(rotation, dtype=float)
    tr = np.asarray(translation, dtype=float)
    if isinstance(obstacle, Mesh):
        return Mesh(vertices=obstacle.vertices @ rot.T + tr, faces=obstacle.faces)
    pos = vec3(rot @ np.asarray(obstacle.position) + tr)
    if isinstance(obstacle, Sphere):
        return Sphere(pos, obstacle.radius)
    quat = quat_xyzw(matrix_to_quat(rot @ quat_to_matrix(np.asarray(obstacle.quaternion_xyzw))))
    if isinstance(obstacle, Box):
        return Box(pos, quat, obstacle.half_extents)
    return type(obstacle)(pos, quat, obstacle.radius, obstacle.half_length)

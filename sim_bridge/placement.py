"""Helpers shared by the scenario generators: generator parameters, resting poses, random convex meshes."""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from typing import Any, TypeVar

import numpy as np
from scipy.spatial import ConvexHull
from scipy.spatial.transform import Rotation

from sim_bridge.scenario import ScenarioError

P = TypeVar("P")


def params_from_dict(cls: type[P], data: Mapping[str, Any] | None, where: str) -> P:
    """Build the parameter dataclass `cls` from a mapping; lists become tuples.

    Raises:
        ScenarioError: an unknown key (naming `where`.<key> and the known ones) or a value that `cls`
            refuses in its ``__post_init__``.
    """
    data = dict(data or {})
    names = [f.name for f in dataclasses.fields(cls)]
    unknown = sorted(set(data) - set(names))
    if unknown:
        raise ScenarioError(f"{where}.{unknown[0]}: unknown parameter (known: {', '.join(names)})")
    kwargs = {k: tuple(v) if isinstance(v, list) else v for k, v in data.items()}
    try:
        return cls(**kwargs)
    except ScenarioError as err:
        raise ScenarioError(f"{where}.{err}") from None
    except (TypeError, ValueError) as err:
        raise ScenarioError(f"{where}: {err}") from None


def check_range(name: str, value: Any, low: float | None = None, high: float | None = None) -> None:
    """Raise ScenarioError('<name>: ...') unless value is a finite number within [low, high]."""
    ok = isinstance(value, int | float) and not isinstance(value, bool) and np.isfinite(value)
    if not ok or (low is not None and value < low) or (high is not None and value > high):
        raise ScenarioError(f"{name}: expected a number in [{low}, {high}], got {value!r}")


def check_interval(name: str, value: Any, low: float | None = None, high: float | None = None) -> None:
    """Raise ScenarioError unless value is a pair (a, b) with low <= a <= b <= high."""
    arr = np.asarray(value, dtype=float) if isinstance(value, tuple | list) else None
    ok = arr is not None and arr.shape == (2,) and bool(np.all(np.isfinite(arr))) and arr[0] <= arr[1]
    if ok and low is not None:
        ok = arr[0] >= low
    if ok and high is not None:
        ok = arr[1] <= high
    if not ok:
        raise ScenarioError(f"{name}: expected [min, max] with {low} <= min <= max <= {high}, got {value!r}")


def resting_height(kind: str, rotation: np.ndarray, sizes: dict[str, Any]) -> float:
    """Height [m] of the object origin above its lowest point for a rotation matrix (3, 3).

    Placing the origin at this z rests the object on the table top (z = 0).
    """
    if kind == "box":
        return float(np.abs(rotation[2]) @ np.asarray(sizes["half_extents"]))
    if kind == "sphere":
        return float(sizes["radius"])
    if kind in ("cylinder", "capsule"):
        az = abs(float(rotation[2, 2]))
        if kind == "capsule":
            return az * sizes["half_length"] + sizes["radius"]
        return az * sizes["half_length"] + sizes["radius"] * float(np.sqrt(max(0.0, 1.0 - az * az)))
    verts = np.asarray(sizes["vertices"]) @ rotation.T
    return float(-verts[:, 2].min())


def random_convex_mesh(rng: np.random.Generator, semi_axes: np.ndarray, n_points: int = 14) -> dict[str, Any]:
    """A random convex polytope: the hull of points on an ellipsoid with semi-axes (3,) [m].

    Returns {"vertices": ((x, y, z), ...), "faces": ((i, j, k), ...)} with outward-facing triangles and
    the origin at the vertices' centroid.
    """
    directions = rng.normal(size=(n_points, 3))
    points = directions / np.linalg.norm(directions, axis=1, keepdims=True) * semi_axes
    hull = ConvexHull(points)
    used = np.unique(hull.simplices)
    remap = -np.ones(len(points), dtype=int)
    remap[used] = np.arange(len(used))
    verts = points[used]
    verts = verts - verts.mean(axis=0)
    faces = remap[hull.simplices]
    centre = verts.mean(axis=0)
    for f in faces:
        a, b, c = verts[f]
        if np.dot(np.cross(b - a, c - a), a - centre) < 0:
            f[1], f[2] = f[2], f[1]
    return {
        "vertices": tuple(tuple(float(x) for x in v) for v in verts),
        "faces": tuple(tuple(int(i) for i in f) for f in faces),
    }


def yaw_quaternion(yaw: float) -> tuple[float, float, float, float]:
    """Quaternion (x, y, z, w) of a rotation by yaw [rad] about world z."""
    return (0.0, 0.0, float(np.sin(yaw / 2)), float(np.cos(yaw / 2)))


def quaternion_xyzw(rotation: Rotation) -> tuple[float, float, float, float]:
    """A scipy Rotation as a (x, y, z, w) tuple with w >= 0."""
    q = rotation.as_quat()
    if q[3] < 0:
        q = -q
    return tuple(float(x) for x in q)

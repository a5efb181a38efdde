"""Scenarios: the objects on the table, how they move, and the target the robot should reach.

ROS-free and MuJoCo-free, so benchmarks and data generators can reuse it. A scenario is either written
by hand (a YAML file listing objects) or produced by a seeded generator (:mod:`sim_bridge.generators`).

All poses are in ``world`` (= panda_link0, table top at z = 0): position [m] and unit quaternion
(x, y, z, w). Object shapes are the obstacle types of the project:

=========  ===========================================================
type       size fields
=========  ===========================================================
box        half_extents [m] (3,)
cylinder   radius [m], half_length [m] (axis = object z)
sphere     radius [m]
capsule    radius [m], half_length [m] of the cylindrical part (axis = z)
mesh       vertices (V, 3) [m] in the object frame, faces (F, 3) vertex indices
=========  ===========================================================

The YAML schema is documented in ``docs/scenarios.md``; :func:`scenario_from_dict` refuses a bad file
with a :class:`ScenarioError` naming the field (e.g. ``objects[2].half_extents``).
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from latent_planner_ros.params.config import ConfigError, from_params
from sim_bridge.camera_config import CameraConfig

SHAPES: dict[str, tuple[str, ...]] = {
    "box": ("half_extents",),
    "cylinder": ("radius", "half_length"),
    "sphere": ("radius",),
    "capsule": ("radius", "half_length"),
    "mesh": ("vertices", "faces"),
}
"""Object type -> its size fields."""

MOTION_MODES = ("wrap", "bounce")
DEFAULT_RGBA = (0.55, 0.6, 0.7, 1.0)


class ScenarioError(ValueError):
    """A scenario (file or dict) is invalid; the message names the offending field."""


Vec3 = tuple[float, float, float]
Quat = tuple[float, float, float, float]


@dataclass(frozen=True)
class Motion:
    """Constant-velocity motion of an object's position inside a travel box.

    Along each axis with a non-zero velocity the position stays in [lower, upper]: on leaving it, the
    object reappears at the other end (``wrap``, a conveyor loop) or reverses (``bounce``). Axes with zero
    velocity keep the initial position. Orientation does not change.

    Attributes:
        velocity: (3,) [m/s] in world.
        lower, upper: (3,) [m] travel bounds of the object's position (only moving axes are used).
        mode: "wrap" or "bounce".
    """

    velocity: Vec3
    lower: Vec3
    upper: Vec3
    mode: str = "wrap"

    def position(self, start: Sequence[float], t: float) -> np.ndarray:
        """Position (3,) [m] at time t [s] of an object that was at `start` (3,) at t = 0."""
        p0, v = np.asarray(start, dtype=float), np.asarray(self.velocity, dtype=float)
        lo, hi = np.asarray(self.lower, dtype=float), np.asarray(self.upper, dtype=float)
        out = p0.copy()
        moving = v != 0.0
        length = (hi - lo)[moving]
        s = (p0 - lo)[moving] + v[moving] * t  # travelled coordinate from the lower end
        if self.mode == "wrap":
            out[moving] = lo[moving] + np.mod(s, length)
        else:
            u = np.mod(s, 2.0 * length)
            out[moving] = lo[moving] + np.where(u <= length, u, 2.0 * length - u)
        return out


@dataclass(frozen=True)
class SceneObject:
    """One rigid object in the scene.

    Attributes:
        name: unique within the scenario.
        type: one of SHAPES.
        position: (3,) [m], quaternion_xyzw: (4,) unit quaternion; the pose of the object frame in world
            at t = 0 (the centre of a primitive; the mesh's origin for a mesh).
        half_extents / radius / half_length / vertices / faces: size fields of the type (see module doc).
        rgba: colour (4,) in [0, 1] for rendering.
        motion: None for a static object.
    """

    name: str
    type: str
    position: Vec3
    quaternion_xyzw: Quat = (0.0, 0.0, 0.0, 1.0)
    half_extents: Vec3 | None = None
    radius: float | None = None
    half_length: float | None = None
    vertices: tuple[Vec3, ...] | None = None
    faces: tuple[tuple[int, int, int], ...] | None = None
    rgba: Quat = DEFAULT_RGBA
    motion: Motion | None = None

    def position_at(self, t: float) -> np.ndarray:
        """Position (3,) [m] in world at scenario time t [s]."""
        if self.motion is None:
            return np.asarray(self.position, dtype=float)
        return self.motion.position(self.position, t)

    def bounding_radius(self) -> float:
        """Radius [m] of a sphere around the object's origin that contains it."""
        if self.type == "box":
            return float(np.linalg.norm(self.half_extents))
        if self.type == "sphere":
            return float(self.radius)
        if self.type == "capsule":
            return float(self.radius + self.half_length)
        if self.type == "cylinder":
            return float(math.hypot(self.radius, self.half_length))
        return float(np.max(np.linalg.norm(np.asarray(self.vertices), axis=1)))


@dataclass(frozen=True)
class Target:
    """The pose the end effector should reach (published on ``target_pose``, like a tag detector).

    Attributes:
        position: (3,) [m] in world, or, when `object` is set, the offset in world axes from that object's
            position (the target then moves with it).
        quaternion_xyzw: (4,) orientation of the end effector (panda_hand_tcp) in world.
        object: name of the object the target follows, or None for a fixed target.
    """

    position: Vec3
    quaternion_xyzw: Quat = (1.0, 0.0, 0.0, 0.0)
    object: str | None = None


@dataclass(frozen=True)
class Scenario:
    """A scene: its objects and an optional target.

    Attributes:
        name: a label (the file or generator name).
        objects: the scene objects (the table is part of every scene and not listed).
        target: the end-effector target, or None.
        description: free text.
        cameras: the scene's own depth cameras (a workcell's fixed cameras), (name, fields) pairs in order: fields
            are CameraConfig values ({"position": ..., "look_at": ...}) replacing the sim's ``camera.*`` ones.
    """

    name: str
    objects: tuple[SceneObject, ...] = ()
    target: Target | None = None
    description: str = ""
    cameras: tuple[tuple[str, dict], ...] = ()

    def object(self, name: str) -> SceneObject:
        """The object called `name`; KeyError naming the known objects otherwise."""
        for obj in self.objects:
            if obj.name == name:
                return obj
        raise KeyError(f"no object {name!r} in scenario {self.name!r} (has {[o.name for o in self.objects]})")

    def target_pose_at(self, t: float) -> tuple[np.ndarray, np.ndarray] | None:
        """Target position (3,) [m] and quaternion_xyzw (4,) at scenario time t [s], or None."""
        if self.target is None:
            return None
        pos = np.asarray(self.target.position, dtype=float)
        if self.target.object is not None:
            pos = self.object(self.target.object).position_at(t) + pos
        return pos, np.asarray(self.target.quaternion_xyzw, dtype=float)

    def to_dict(self) -> dict[str, Any]:
        """Plain-YAML form (the inverse of :func:`scenario_from_dict`)."""
        out: dict[str, Any] = {"name": self.name}
        if self.description:
            out["description"] = self.description
        out["objects"] = [_object_to_dict(o) for o in self.objects]
        if self.target is not None:
            target = {"position": list(self.target.position), "quaternion_xyzw": list(self.target.quaternion_xyzw)}
            if self.target.object is not None:
                target["object"] = self.target.object
            out["target"] = target
        return out


def _object_to_dict(obj: SceneObject) -> dict[str, Any]:
    out: dict[str, Any] = {"name": obj.name, "type": obj.type}
    for key in SHAPES[obj.type]:
        value = getattr(obj, key)
        out[key] = [list(v) for v in value] if key in ("vertices", "faces") else _plain(value)
    out["position"] = list(obj.position)
    out["quaternion_xyzw"] = list(obj.quaternion_xyzw)
    out["rgba"] = list(obj.rgba)
    if obj.motion is not None:
        m = obj.motion
        out["motion"] = {
            "velocity": list(m.velocity),
            "lower": list(m.lower),
            "upper": list(m.upper),
            "mode": m.mode,
        }
    return out


def _plain(value):
    return list(value) if isinstance(value, tuple) else value


# ----------------------------------------------------------------------------------------------------
# Parsing and validation


@dataclass
class _Reader:
    """Reads typed fields of one mapping, naming `where` in every error."""

    data: Mapping[str, Any]
    where: str
    allowed: tuple[str, ...]
    used: set[str] = field(default_factory=set)

    def __post_init__(self) -> None:
        if not isinstance(self.data, Mapping):
            raise ScenarioError(f"{self.where}: expected a mapping, got {type(self.data).__name__}")
        unknown = sorted(set(map(str, self.data)) - set(self.allowed))
        if unknown:
            raise ScenarioError(f"{self._at(unknown[0])}: unknown field (allowed: {', '.join(self.allowed)})")

    def _at(self, key: str) -> str:
        return f"{self.where}.{key}" if self.where else key

    def has(self, key: str) -> bool:
        return key in self.data

    def raw(self, key: str, default: Any = ...) -> Any:
        if key not in self.data:
            if default is ...:
                raise ScenarioError(f"{self._at(key)}: missing")
            return default
        return self.data[key]

    def string(self, key: str, default: Any = ...) -> str:
        value = self.raw(key, default)
        if not isinstance(value, str) or not value:
            raise ScenarioError(f"{self._at(key)}: expected a non-empty string, got {value!r}")
        return value

    def number(self, key: str, positive: bool = False, default: Any = ...) -> float:
        value = self.raw(key, default)
        ok = isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(value)
        if not ok or (positive and value <= 0):
            kind = "a positive number" if positive else "a finite number"
            raise ScenarioError(f"{self._at(key)}: expected {kind}, got {value!r}")
        return float(value)

    def vector(self, key: str, n: int, positive: bool = False, default: Any = ...) -> tuple[float, ...]:
        value = self.raw(key, default)
        arr = _as_array(value)
        ok = arr is not None and arr.shape == (n,) and bool(np.all(np.isfinite(arr)))
        if ok and positive:
            ok = bool(np.all(arr > 0))
        if not ok:
            kind = f"{n} positive numbers" if positive else f"{n} finite numbers"
            raise ScenarioError(f"{self._at(key)}: expected {kind}, got {value!r}")
        return tuple(float(x) for x in arr)


def _as_array(value: Any) -> np.ndarray | None:
    if isinstance(value, str | bytes | Mapping):
        return None
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        return None
    return arr


def _quaternion(reader: _Reader, key: str, default: Any = ...) -> Quat:
    q = np.asarray(reader.vector(key, 4, default=default))
    norm = float(np.linalg.norm(q))
    if norm < 1e-6:
        raise ScenarioError(f"{reader._at(key)}: quaternion (x, y, z, w) has zero norm")
    return tuple(float(x) for x in q / norm)


def _motion(data: Any, where: str, position: Vec3) -> Motion:
    r = _Reader(data, where, ("velocity", "lower", "upper", "mode"))
    velocity = r.vector("velocity", 3)
    lower, upper = r.vector("lower", 3), r.vector("upper", 3)
    mode = r.string("mode", default="wrap")
    if mode not in MOTION_MODES:
        raise ScenarioError(f"{where}.mode: expected one of {MOTION_MODES}, got {mode!r}")
    for k, axis in enumerate("xyz"):
        if velocity[k] == 0.0:
            continue
        if not upper[k] > lower[k]:
            raise ScenarioError(f"{where}.upper: must exceed lower along the moving axis {axis}")
        if not lower[k] <= position[k] <= upper[k]:
            raise ScenarioError(
                f"{where}: the object's position {axis} = {position[k]} is outside [lower, upper] = "
                f"[{lower[k]}, {upper[k]}]"
            )
    return Motion(velocity=velocity, lower=lower, upper=upper, mode=mode)


def _mesh(r: _Reader, where: str) -> tuple[tuple[Vec3, ...], tuple[tuple[int, int, int], ...]]:
    verts = _as_array(r.raw("vertices"))
    if verts is None or verts.ndim != 2 or verts.shape[1] != 3 or len(verts) < 4 or not np.all(np.isfinite(verts)):
        raise ScenarioError(f"{where}.vertices: expected a list of at least 4 [x, y, z] points")
    faces = _as_array(r.raw("faces"))
    if faces is None or faces.ndim != 2 or faces.shape[1] != 3 or len(faces) < 4:
        raise ScenarioError(f"{where}.faces: expected a list of at least 4 [i, j, k] vertex index triples")
    if not np.all(faces == np.round(faces)) or faces.min() < 0 or faces.max() >= len(verts):
        raise ScenarioError(f"{where}.faces: indices must be integers in [0, {len(verts) - 1}]")
    if np.linalg.matrix_rank(verts - verts.mean(axis=0), tol=1e-6) < 3:
        raise ScenarioError(f"{where}.vertices: the mesh is flat (all vertices in a plane); it needs a volume")
    return tuple(tuple(float(x) for x in v) for v in verts), tuple(tuple(int(i) for i in f) for f in faces)


OBJECT_FIELDS = (
    "name",
    "type",
    "position",
    "quaternion_xyzw",
    "half_extents",
    "radius",
    "half_length",
    "vertices",
    "faces",
    "rgba",
    "motion",
)


def object_from_dict(data: Any, where: str = "object") -> SceneObject:
    """Validate one object mapping; ScenarioError naming `where`.<field> on a problem."""
    r = _Reader(data, where, OBJECT_FIELDS)
    name = r.string("name")
    kind = r.string("type")
    if kind not in SHAPES:
        raise ScenarioError(f"{where}.type: expected one of {tuple(SHAPES)}, got {kind!r}")
    other_sizes = {k for fields in SHAPES.values() for k in fields} - set(SHAPES[kind])
    extra = sorted(other_sizes & set(map(str, data)))
    if extra:
        raise ScenarioError(f"{where}.{extra[0]}: not a field of a {kind} (it has {', '.join(SHAPES[kind])})")
    sizes: dict[str, Any] = {}
    if kind == "box":
        sizes["half_extents"] = r.vector("half_extents", 3, positive=True)
    elif kind == "mesh":
        sizes["vertices"], sizes["faces"] = _mesh(r, where)
    else:
        sizes["radius"] = r.number("radius", positive=True)
        if kind != "sphere":
            sizes["half_length"] = r.number("half_length", positive=True)
    position = r.vector("position", 3)
    rgba = r.vector("rgba", 4, default=DEFAULT_RGBA)
    if not all(0.0 <= c <= 1.0 for c in rgba):
        raise ScenarioError(f"{where}.rgba: components must be in [0, 1], got {list(rgba)}")
    motion = _motion(r.raw("motion"), f"{where}.motion", position) if r.has("motion") else None
    return SceneObject(
        name=name,
        type=kind,
        position=position,
        quaternion_xyzw=_quaternion(r, "quaternion_xyzw", default=(0.0, 0.0, 0.0, 1.0)),
        rgba=rgba,
        motion=motion,
        **sizes,
    )


SCENARIO_FIELDS = ("name", "description", "objects", "target", "cameras")
CAMERA_NAME = re.compile(r"[A-Za-z][A-Za-z0-9_]*")
"""A camera name: one ROS name token (its topics are ``<name>/points`` and ``<name>/pose``)."""


def cameras_from_dict(data: Any, where: str = "cameras") -> tuple[tuple[str, dict], ...]:
    """Validate a scenario's ``cameras`` mapping {name: {CameraConfig field: value}} (order kept).

    Each camera's fields are checked by building a CameraConfig of them over the defaults.

    Raises:
        ScenarioError: naming the camera and field.
    """
    if data is None:
        return ()
    if not isinstance(data, Mapping):
        raise ScenarioError(f"{where}: expected a mapping of camera name -> camera fields")
    out = []
    for name, fields in data.items():
        if not isinstance(name, str) or not CAMERA_NAME.fullmatch(name):
            raise ScenarioError(f"{where}: camera name {name!r} is not a ROS name token ([A-Za-z][A-Za-z0-9_]*)")
        if not isinstance(fields, Mapping):
            raise ScenarioError(f"{where}.{name}: expected a mapping of camera fields (position, look_at, ...)")
        try:
            from_params(CameraConfig, dict(fields))
        except ConfigError as err:
            raise ScenarioError(f"{where}.{name}.{err}") from None
        out.append((name, {k: list(v) if isinstance(v, list | tuple) else v for k, v in fields.items()}))
    return tuple(out)


def scenario_from_dict(data: Any, where: str = "") -> Scenario:
    """Validate a scenario mapping (the YAML schema of a hand-written scene).

    Raises:
        ScenarioError: naming the field, e.g. ``objects[1].radius: expected a positive number, got -1``.
    """
    r = _Reader(data, where, SCENARIO_FIELDS)
    name = r.string("name", default="scenario")
    description = r.raw("description", default="")
    if not isinstance(description, str):
        raise ScenarioError(f"{r._at('description')}: expected a string")
    raw_objects = r.raw("objects", default=[]) or []
    if not isinstance(raw_objects, list):
        raise ScenarioError(f"{r._at('objects')}: expected a list of objects")
    objects = tuple(object_from_dict(o, r._at(f"objects[{i}]")) for i, o in enumerate(raw_objects))
    seen: set[str] = set()
    for i, obj in enumerate(objects):
        if obj.name in seen:
            raise ScenarioError(f"{r._at(f'objects[{i}]')}.name: duplicate object name {obj.name!r}")
        seen.add(obj.name)
    target = None
    if r.has("target") and r.raw("target") is not None:
        where_t = r._at("target")
        t = _Reader(r.raw("target"), where_t, ("position", "quaternion_xyzw", "object"))
        follow = t.string("object") if t.raw("object", default=None) is not None else None
        if follow is not None and follow not in seen:
            raise ScenarioError(f"{where_t}.object: no object named {follow!r} (objects: {sorted(seen)})")
        target = Target(
            position=t.vector("position", 3),
            quaternion_xyzw=_quaternion(t, "quaternion_xyzw", default=(1.0, 0.0, 0.0, 0.0)),
            object=follow,
        )
    cameras = cameras_from_dict(r.raw("cameras", default=None), r._at("cameras"))
    return Scenario(name=name, objects=objects, target=target, description=description, cameras=cameras)

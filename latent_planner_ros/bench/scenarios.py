"""Benchmark scenario sets: reaching problems in tabletop scenes, as JSON files anyone can write.

Schema (frame `world` = `panda_link0`, table top at z = 0, lengths in metres, angles in radians):

    {"name": str,
     "table": bool,                         # the table top (z < 0) is an obstacle and is seen by the camera
     "description": str,                    # optional
     "frame": "world",                      # optional; "panda_link0" is accepted as a synonym
     "problems": [
       {"start": [7],                       # start configuration [rad], within the joint limits
        "goal": {"position": [3], "quaternion_xyzw": [4]},   # target pose of panda_hand_tcp
        "goal_q": [7],                      # optional: a configuration reaching the goal (never given to planners)
        "obstacles": [...],                 # the TRUE geometry (data/obstacles.py schema), used to render the
                                            # cloud and to check results; planners never see it
        "camera": {"eye": [3], "target": [3], "seed": int},  # optional viewpoint and depth-noise seed
        "cameras": [{"eye": [3], "target": [3], "seed": int}, ...],  # optional, instead of "camera":
                                            # several views whose clouds are fused in `world`
        "family": str,                      # optional scene family, for per-family reports ("bookshelf", ...)
        "inside": bool,                     # optional: the goal lies inside furniture (a shelf slot, a bin)
        "grasp": bool,                      # optional: the goal is a grasp (TCP at an object, open fingers
                                            # around it): planned through planning/grasp.plan_grasp
        "target": int,                      # optional (grasp only): index into "obstacles" of the object grasped
        "approach_m": float                 # optional (grasp only): pre-grasp distance [m] back along the
                                            # hand's z axis (default: the harness's)
       }, ...]}

Obstacles: {"type": "box", "position", "quaternion_xyzw", "half_extents"} | {"type": "cylinder", "position",
"quaternion_xyzw", "radius", "half_length"} | {"type": "sphere", "position", "radius"} | {"type": "capsule",
... as cylinder} | {"type": "mesh", "vertices", "faces"}; "quaternion_xyzw" defaults to identity; each may carry
a "name". Without a camera (neither "camera" nor "cameras") the harness draws a viewpoint from the default
camera ranges, seeded by the problem's index, so every run of a set sees the same clouds.

A malformed file raises ScenarioError naming the file and the field, e.g.
``tabletop.json: problems[3].goal.quaternion_xyzw: must be 4 finite numbers, got [0, 0, 1]``.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from latent_planner_ros.data.camera import look_at
from latent_planner_ros.data.obstacles import Obstacle, obstacle_from_dict, obstacle_to_dict
from latent_planner_ros.data.scene import Scene
from latent_planner_ros.resources import find_resource
from latent_planner_ros.robot.limits import Q_MAX, Q_MIN

DEFAULT_SET = find_resource("bench/scenarios", "tabletop_heldout_100.json")
"""The shipped default set: 100 held-out tabletop scenes (written by `bench.scenario_generator`); the checkout's
latent_planner_ros/bench/scenarios, or an install's share/latent_planner_ros/bench/scenarios."""

LIMIT_SLACK = 1e-3
"""start / goal_q may lie this far [rad] outside the joint limits (rounding)"""

_OBSTACLE_KEYS = {
    "box": {"position", "quaternion_xyzw", "half_extents"},
    "cylinder": {"position", "quaternion_xyzw", "radius", "half_length"},
    "capsule": {"position", "quaternion_xyzw", "radius", "half_length"},
    "sphere": {"position", "radius"},
    "mesh": {"vertices", "faces"},
}


_PROBLEM_KEYS = {
    "start", "goal", "goal_q", "obstacles", "camera", "cameras", "name", "family", "inside", "grasp", "target",
    "approach_m",
}  # fmt: skip


class ScenarioError(ValueError):
    """A scenario file or dict that does not follow the schema; the message names the field."""


@dataclass(frozen=True)
class CameraSpec:
    """A fixed viewpoint: camera at `eye` (3,) [m] looking at `target` (3,) [m]; `seed` seeds the depth noise."""

    eye: tuple[float, float, float]
    target: tuple[float, float, float]
    seed: int | None = None

    def pose(self) -> np.ndarray:
        """(4, 4) camera-to-world pose (optical frame: z forward, image y down)."""
        return look_at(np.asarray(self.eye), np.asarray(self.target))


@dataclass(frozen=True)
class ScenarioProblem:
    """One problem of a set.

    Attributes:
        start: (7,) start configuration [rad].
        goal_position: (3,) TCP target position [m].
        goal_quaternion_xyzw: (4,) TCP target orientation (unit quaternion).
        obstacles: the true obstacle geometry.
        goal_q: (7,) a configuration reaching the goal, or None.
        cameras: fixed viewpoints whose clouds are fused; empty = one drawn from the default camera ranges.
        family: the scene family ("" = unnamed), for per-family reports.
        inside: the goal lies inside furniture (a shelf slot, a bin).
        grasp: the goal is a grasp of an object (planned with planning/grasp.plan_grasp).
        target: index into obstacles of the grasped object, or None.
        approach_m: the grasp's pre-grasp distance [m], or None (the harness's default).
    """

    start: np.ndarray
    goal_position: np.ndarray
    goal_quaternion_xyzw: np.ndarray
    obstacles: tuple[Obstacle, ...] = ()
    goal_q: np.ndarray | None = None
    cameras: tuple[CameraSpec, ...] = ()
    family: str = ""
    inside: bool = False
    grasp: bool = False
    target: int | None = None
    approach_m: float | None = None

    def __post_init__(self):
        if isinstance(self.cameras, CameraSpec):  # a single view passed positionally, as before
            object.__setattr__(self, "cameras", (self.cameras,))
        elif self.cameras is None:
            object.__setattr__(self, "cameras", ())
        else:
            object.__setattr__(self, "cameras", tuple(self.cameras))

    @property
    def camera(self) -> CameraSpec | None:
        """The first fixed viewpoint, or None."""
        return self.cameras[0] if self.cameras else None

    @property
    def scene(self) -> Scene:
        return Scene(obstacles=self.obstacles, family="scenario")

    def to_dict(self, digits: int | None = None) -> dict:
        """The schema dict; `digits` rounds every number (None keeps full precision)."""

        def r(x):
            a = np.asarray(x, dtype=float)
            return (np.round(a, digits) if digits is not None else a).tolist()

        out: dict[str, Any] = {
            "start": r(self.start),
            "goal": {"position": r(self.goal_position), "quaternion_xyzw": r(self.goal_quaternion_xyzw)},
        }
        if self.goal_q is not None:
            out["goal_q"] = r(self.goal_q)
        out["obstacles"] = [round_obstacle(obstacle_to_dict(o), digits) for o in self.obstacles]

        def view(c: CameraSpec) -> dict:
            v: dict[str, Any] = {"eye": r(c.eye), "target": r(c.target)}
            if c.seed is not None:
                v["seed"] = int(c.seed)
            return v

        if len(self.cameras) == 1:
            out["camera"] = view(self.cameras[0])
        elif self.cameras:
            out["cameras"] = [view(c) for c in self.cameras]
        if self.family:
            out["family"] = self.family
        if self.inside:
            out["inside"] = True
        if self.grasp:
            out["grasp"] = True
        if self.target is not None:
            out["target"] = int(self.target)
        if self.approach_m is not None:
            out["approach_m"] = float(self.approach_m)
        return out


@dataclass(frozen=True)
class ScenarioSet:
    """A named list of problems; `table`: the table top is an obstacle (and is rendered)."""

    name: str
    problems: tuple[ScenarioProblem, ...]
    table: bool = True
    description: str = ""
    extra: dict = field(default_factory=dict)
    """provenance written by a generator (seed, settings); free-form, kept on round trips"""

    def to_dict(self, digits: int | None = None) -> dict:
        out: dict[str, Any] = {"name": self.name, "frame": "world", "table": self.table}
        if self.description:
            out["description"] = self.description
        if self.extra:
            out["generator"] = self.extra
        out["problems"] = [p.to_dict(digits) for p in self.problems]
        return out

    def head(self, n: int | None) -> ScenarioSet:
        """The first n problems (all when n is None)."""
        if n is None:
            return self
        return ScenarioSet(self.name, self.problems[:n], self.table, self.description, self.extra)


DIGITS = 6
"""decimals kept in a scenario file by the generators (micrometres, micro-radians)"""


# -- parsing -------------------------------------------------------------------------------------------
def round_obstacle(d: dict, digits: int | None) -> dict:
    """An obstacle dict with its numbers rounded to `digits` decimals (faces kept)."""
    if digits is None:
        return d
    return {
        k: (v if k in ("type", "faces") else np.round(np.asarray(v, dtype=float), digits).tolist())
        for k, v in d.items()
    }


def _vector(d: dict, key: str, n: int, where: str) -> np.ndarray:
    if key not in d:
        raise ScenarioError(f"{where}.{key}: missing")
    try:
        a = np.asarray(d[key], dtype=float)
    except (TypeError, ValueError):
        a = np.zeros(0)
    if a.shape != (n,) or not np.all(np.isfinite(a)):
        raise ScenarioError(f"{where}.{key}: must be {n} finite numbers, got {d[key]!r}")
    return a


def _no_extra_keys(d: dict, allowed: set[str], where: str) -> None:
    extra = sorted(set(d) - allowed)
    if extra:
        raise ScenarioError(f"{where}: unknown field(s) {extra}; allowed: {sorted(allowed)}")


def _configuration(d: dict, key: str, where: str) -> np.ndarray:
    q = _vector(d, key, 7, where)
    bad = np.flatnonzero((q < Q_MIN - LIMIT_SLACK) | (q > Q_MAX + LIMIT_SLACK))
    if bad.size:
        j = int(bad[0])
        raise ScenarioError(
            f"{where}.{key}: joint {j + 1} = {q[j]:.4f} rad is outside its limits [{Q_MIN[j]:.4f}, {Q_MAX[j]:.4f}]"
        )
    return np.clip(q, Q_MIN, Q_MAX)


def _obstacle(d: Any, where: str) -> Obstacle:
    if not isinstance(d, dict):
        raise ScenarioError(f"{where}: must be an object with a 'type', got {d!r}")
    kind = d.get("type")
    if kind not in _OBSTACLE_KEYS:
        raise ScenarioError(f"{where}.type: must be one of {sorted(_OBSTACLE_KEYS)}, got {kind!r}")
    _no_extra_keys(d, _OBSTACLE_KEYS[kind] | {"type", "name"}, where)
    required = sorted(_OBSTACLE_KEYS[kind] - {"quaternion_xyzw"})
    for key in required:
        if key not in d:
            raise ScenarioError(f"{where}.{key}: missing (a {kind} needs {', '.join(required)})")
    try:
        return obstacle_from_dict({k: v for k, v in d.items() if k != "name"})
    except (ValueError, TypeError) as err:
        msg = str(err)
        named = next((k for k in sorted(_OBSTACLE_KEYS[kind], key=len, reverse=True) if k in msg), None)
        raise ScenarioError(f"{where}.{named}: {msg}" if named else f"{where}: {msg}") from None


def _camera(d: Any, where: str) -> CameraSpec:
    if not isinstance(d, dict):
        raise ScenarioError(f"{where}: must be an object {{eye, target, seed}}, got {d!r}")
    _no_extra_keys(d, {"eye", "target", "seed"}, where)
    eye, target = _vector(d, "eye", 3, where), _vector(d, "target", 3, where)
    if np.linalg.norm(eye - target) < 1e-3:
        raise ScenarioError(f"{where}.target: must differ from eye")
    seed = d.get("seed")
    if seed is not None and (isinstance(seed, bool) or not isinstance(seed, int) or seed < 0):
        raise ScenarioError(f"{where}.seed: must be a non-negative integer, got {seed!r}")
    return CameraSpec(tuple(eye.tolist()), tuple(target.tolist()), seed)


def problem_from_dict(d: Any, where: str = "problem") -> ScenarioProblem:
    """Parse one problem dict; raises ScenarioError naming the field (prefixed by `where`)."""
    if not isinstance(d, dict):
        raise ScenarioError(f"{where}: must be an object, got {type(d).__name__}")
    _no_extra_keys(d, _PROBLEM_KEYS, where)
    start = _configuration(d, "start", where)
    goal = d.get("goal")
    if not isinstance(goal, dict):
        raise ScenarioError(f"{where}.goal: must be an object {{position, quaternion_xyzw}}, got {goal!r}")
    _no_extra_keys(goal, {"position", "quaternion_xyzw"}, f"{where}.goal")
    position = _vector(goal, "position", 3, f"{where}.goal")
    quat = _vector(goal, "quaternion_xyzw", 4, f"{where}.goal")
    norm = float(np.linalg.norm(quat))
    if not math.isclose(norm, 1.0, abs_tol=1e-3):
        raise ScenarioError(f"{where}.goal.quaternion_xyzw: must be a unit quaternion, norm is {norm:.4g}")
    goal_q = _configuration(d, "goal_q", where) if d.get("goal_q") is not None else None
    obstacles = d.get("obstacles", [])
    if not isinstance(obstacles, list):
        raise ScenarioError(f"{where}.obstacles: must be a list, got {type(obstacles).__name__}")
    parsed = tuple(_obstacle(o, f"{where}.obstacles[{j}]") for j, o in enumerate(obstacles))
    return ScenarioProblem(
        start, position, quat / norm, parsed, goal_q, _cameras(d, where), *_labels(d, where), *_grasp(d, where, parsed)
    )


def _cameras(d: dict, where: str) -> tuple[CameraSpec, ...]:
    """The problem's "camera" (one view) or "cameras" (a non-empty list), not both."""
    if d.get("camera") is not None and d.get("cameras") is not None:
        raise ScenarioError(f"{where}: give either 'camera' or 'cameras', not both")
    if d.get("camera") is not None:
        return (_camera(d["camera"], f"{where}.camera"),)
    views = d.get("cameras")
    if views is None:
        return ()
    if not isinstance(views, list) or not views:
        raise ScenarioError(f"{where}.cameras: must be a non-empty list of {{eye, target, seed}}, got {views!r}")
    return tuple(_camera(v, f"{where}.cameras[{i}]") for i, v in enumerate(views))


def _labels(d: dict, where: str) -> tuple[str, bool]:
    """The problem's optional "family" (a string) and "inside" (a bool)."""
    family, inside = d.get("family", ""), d.get("inside", False)
    if not isinstance(family, str):
        raise ScenarioError(f"{where}.family: must be a string, got {family!r}")
    if not isinstance(inside, bool):
        raise ScenarioError(f"{where}.inside: must be true or false, got {inside!r}")
    return family, inside


def _grasp(d: dict, where: str, obstacles: tuple) -> tuple[bool, int | None, float | None]:
    """The problem's optional "grasp" (a bool), "target" (an obstacle index) and "approach_m" (metres >= 0);
    the last two only for a grasp."""
    grasp, target, approach = d.get("grasp", False), d.get("target"), d.get("approach_m")
    if not isinstance(grasp, bool):
        raise ScenarioError(f"{where}.grasp: must be true or false, got {grasp!r}")
    for key, value in (("target", target), ("approach_m", approach)):
        if value is not None and not grasp:
            raise ScenarioError(f'{where}.{key}: only for a grasp problem ("grasp": true)')
    if target is not None and (
        isinstance(target, bool) or not isinstance(target, int) or not 0 <= target < len(obstacles)
    ):
        raise ScenarioError(
            f"{where}.target: must be an index into obstacles (0..{len(obstacles) - 1}), got {target!r}"
        )
    if approach is not None and (
        isinstance(approach, bool)
        or not isinstance(approach, int | float)
        or not math.isfinite(approach)
        or approach < 0
    ):
        raise ScenarioError(f"{where}.approach_m: must be a non-negative number of metres, got {approach!r}")
    return grasp, target, None if approach is None else float(approach)


def set_from_dict(d: Any, source: str = "scenario set") -> ScenarioSet:
    """Parse a whole set; raises ScenarioError "<source>: <field>: <problem>"."""
    try:
        if not isinstance(d, dict):
            raise ScenarioError(f"top level: must be an object, got {type(d).__name__}")
        _no_extra_keys(d, {"name", "table", "problems", "frame", "description", "generator"}, "top level")
        if not isinstance(d.get("name"), str) or not d["name"]:
            raise ScenarioError(f"name: must be a non-empty string, got {d.get('name')!r}")
        if not isinstance(d.get("table"), bool):
            raise ScenarioError(f"table: must be true or false, got {d.get('table')!r}")
        if d.get("frame", "world") not in ("world", "panda_link0"):
            raise ScenarioError(f"frame: must be 'world' (= panda_link0), got {d.get('frame')!r}")
        problems = d.get("problems")
        if not isinstance(problems, list) or not problems:
            raise ScenarioError("problems: must be a non-empty list")
        parsed = tuple(problem_from_dict(p, f"problems[{i}]") for i, p in enumerate(problems))
        extra = d.get("generator", {})
        return ScenarioSet(d["name"], parsed, d["table"], str(d.get("description", "")), dict(extra or {}))
    except ScenarioError as err:
        raise ScenarioError(f"{source}: {err}") from None


def load_scenarios(path: str | Path | None = None) -> ScenarioSet:
    """Load a set (default: the shipped DEFAULT_SET); raises ScenarioError (also for unreadable JSON)."""
    path = Path(DEFAULT_SET if path is None else path)
    try:
        data = json.loads(path.read_text())
    except OSError as err:
        raise ScenarioError(f"{path}: cannot read: {err.strerror or err}") from None
    except json.JSONDecodeError as err:
        raise ScenarioError(f"{path}: not valid JSON: {err}") from None
    return set_from_dict(data, str(path.name))


def save_scenarios(scenarios: ScenarioSet, path: str | Path, digits: int | None = 6) -> Path:
    """Write a set as JSON, one problem per line; numbers rounded to `digits` decimals."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    d = scenarios.to_dict(digits)
    problems = d.pop("problems")
    head = json.dumps(d, separators=(",", ":"))[:-1]
    lines = ",\n".join(json.dumps(p, separators=(",", ":")) for p in problems)
    path.write_text(f'{head},"problems":[\n{lines}\n]}}\n')
    return path

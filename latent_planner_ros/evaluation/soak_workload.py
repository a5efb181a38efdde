"""The randomised, seeded workload of ``bench soak``: a timeline of events for the node suite. No ROS.

Each :class:`Event` happens at a time [s] of simulated time from the soak's start:

- ``scenario``: the sim switches scenario (``tabletop`` and ``conveyor`` alternate, each with a fresh seed; the
  conveyor's belt speed, direction, wrap or bounce drawn as in ``bench conveyor``) and resets the scene;
- ``goal``: a new TCP goal on ``goal_pose`` every ``goal_interval_s``: ``reachable`` (a pose above the table in
  front of the arm, hand pointing down), ``unreachable`` (beyond the arm's reach), ``inside_obstacle`` (at the
  centre or on the top face of a still object; tabletop only) or ``conveyor_target`` (the sim's moving target
  relayed to ``goal_pose``; conveyor only; its obstacle moves along the belt);
- ``grasp_goal``: now and then (tabletop only, still objects) a goal on ``grasp_pose`` at an object, from above;
- ``camera_dropout``: ``camera/points`` stops reaching the planner and the encoder for ``dropout_s``;
- ``joint_pause``: ``joint_states`` stops reaching the planner for ``pause_s`` (a driver's hiccup);
- ``param_change``: a planner parameter set at run time, a valid ``closed_loop.*`` value (expected: accepted)
  or a bad one (expected: refused with a reason);
- ``plan_request``: a one-shot ``planner/plan`` while the closed loop tracks (some with a negative tolerance,
  which must be refused with a reason).

Objects are chosen by a draw ``u`` in [0, 1) (the object ``floor(u * n)`` of the scene's n candidates), so the
timeline does not depend on the scenes, which the driver resolves when it applies an event.

    events = generate(minutes=30, seed=0)      # sorted by time, every kind present
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

EVENT_KINDS = (
    "scenario",
    "goal",
    "grasp_goal",
    "camera_dropout",
    "joint_pause",
    "param_change",
    "plan_request",
)
GOAL_KINDS = ("reachable", "unreachable", "inside_obstacle", "conveyor_target")
SCENARIOS = ("tabletop", "conveyor")

GOOD_PARAMS = {
    "closed_loop.goal_lead_s": (0.1, 0.5),
    "closed_loop.tick_budget_ms": (15.0, 30.0),
    "closed_loop.servo_radius_m": (0.2, 0.5),
    "closed_loop.evade_margin_m": (0.03, 0.07),
    "closed_loop.no_progress_s": (6.0, 10.0),
}
"""Planner parameters changed at run time, each drawn uniformly from this range (all inside the valid range)."""
BAD_PARAMS = (
    ("closed_loop.rate_hz", 0.0),
    ("closed_loop.goal_lead_s", -0.5),
    ("closed_loop.max_iterations_per_tick", 0),
    ("closed_loop.stale_scene_s", -1.0),
    ("amp_ls.col_threshold", 1.5),
)
"""Values outside the valid range: the planner must refuse them with a reason naming the parameter."""

SHOULDER = (0.0, 0.0, 0.333)
"""[m] the Panda's shoulder in world (goals farther than the planner's reach_m from it are out of reach)."""


@dataclass(frozen=True)
class WorkloadConfig:
    """Rates and ranges of the workload. Intervals [s] of simulated time are drawn uniformly from (low, high).

    Attributes:
        goal_interval_s: time between two goals.
        scenario_period_s: time between two scenario switches (at most half the soak, so both scenarios run).
        dropout_every_s, dropout_s: time between camera dropouts, and their length.
        pause_every_s, pause_s: time between joint-state pauses, and their length.
        param_every_s: time between parameter changes; bad_param_share: the share of refused (bad) values.
        plan_every_s: time between one-shot plan requests; bad_tolerance_share: the share with tolerance -1.
        grasp_share: the share of tabletop goals sent as grasp goals.
        goal_mix: weights of reachable, unreachable, inside_obstacle goals (tabletop) and of reachable,
            unreachable, conveyor_target goals (conveyor), in that order.
        reach_box: (low xyz, high xyz) [m] of reachable goal positions in world.
        unreachable_m: distances [m] from the shoulder of unreachable goals.
        belt_speed: [m/s] conveyor belt speed range (its sign drawn too).
    """

    goal_interval_s: tuple[float, float] = (2.0, 10.0)
    scenario_period_s: tuple[float, float] = (90.0, 180.0)
    dropout_every_s: tuple[float, float] = (20.0, 60.0)
    dropout_s: tuple[float, float] = (0.5, 3.0)
    pause_every_s: tuple[float, float] = (20.0, 60.0)
    pause_s: tuple[float, float] = (0.05, 0.8)
    param_every_s: tuple[float, float] = (20.0, 60.0)
    bad_param_share: float = 0.3
    plan_every_s: tuple[float, float] = (10.0, 30.0)
    bad_tolerance_share: float = 0.2
    grasp_share: float = 0.15
    goal_mix: tuple[float, float, float] = (0.6, 0.2, 0.2)
    reach_box: tuple[tuple[float, float, float], tuple[float, float, float]] = ((0.3, -0.35, 0.25), (0.6, 0.35, 0.55))
    unreachable_m: tuple[float, float] = (1.15, 1.5)
    belt_speed: tuple[float, float] = (0.03, 0.08)


@dataclass(frozen=True)
class Event:
    """One thing the soak does: at time t [s] (simulated, from the start), of `kind`, with JSON-ready params."""

    t: float
    kind: str
    params: dict = field(default_factory=dict)

    def to_dict(self) -> dict:
        return {"t": round(self.t, 3), "kind": self.kind, **self.params}


def _r(x: float) -> float:
    return round(float(x), 4)


def reachable_pose(rng: np.random.Generator, cfg: WorkloadConfig) -> dict:
    """{"position": (3,) [m], "yaw": [rad]}: a pose in reach_box, the hand pointing down, turned by yaw."""
    low, high = np.asarray(cfg.reach_box[0]), np.asarray(cfg.reach_box[1])
    return {"position": [_r(v) for v in rng.uniform(low, high)], "yaw": _r(rng.uniform(-np.pi / 2, np.pi / 2))}


def unreachable_pose(rng: np.random.Generator, cfg: WorkloadConfig) -> dict:
    """A pose unreachable_m from the shoulder, above the table, in a random direction."""
    azimuth = rng.uniform(-np.pi, np.pi)
    elevation = rng.uniform(-0.2, 1.2)
    d = rng.uniform(*cfg.unreachable_m)
    direction = np.array([np.cos(elevation) * np.cos(azimuth), np.cos(elevation) * np.sin(azimuth), np.sin(elevation)])
    position = np.asarray(SHOULDER) + d * direction
    position[2] = max(position[2], 0.05)
    return {"position": [_r(v) for v in position], "yaw": 0.0}


def _periodic(rng, kind, every, total, make) -> list[Event]:
    """Events of one kind every U(every) s; the first within min(every high, 0.8 total) so short runs get one."""
    t = rng.uniform(1.0, max(1.5, min(every[1], 0.8 * total)))
    out = []
    while t < total:
        out.append(Event(float(t), kind, make(rng)))
        t += rng.uniform(*every)
    return out


def generate(minutes: float, seed: int = 0, config: WorkloadConfig | None = None) -> list[Event]:
    """The events of a soak of `minutes` [min] of simulated time, sorted by time; the same for the same seed.

    The first event (t = 0) is a tabletop scenario; scenarios alternate every scenario_period_s (at most half the
    soak). Goals follow every goal_interval_s from t = 1 s, their kinds drawn by goal_mix for the scenario running
    then. A joint-state pause that would span a scenario switch is left out (drawn, so the other events stay
    those of the seed): the switch resets the sim and puts the arm back at its start, a jump that no real arm
    makes and that the planner cannot see while its joint states are withheld (soak60c's one violation).
    """
    cfg = config or WorkloadConfig()
    total = 60.0 * float(minutes)
    if total <= 0:
        raise ValueError(f"minutes must be > 0, got {minutes}")
    rng = np.random.default_rng(seed)
    events: list[Event] = []
    phases: list[tuple[float, str]] = []
    t, k = 0.0, 0
    while t < total:
        name = SCENARIOS[k % 2]
        params = {"scenario": name, "seed": int(rng.integers(0, 2**31 - 1)), "overrides": ""}
        if name == "conveyor":
            speed = rng.uniform(*cfg.belt_speed) * rng.choice([-1.0, 1.0])
            params["overrides"] = f"{{speed: {speed:.4f}, mode: {rng.choice(['wrap', 'bounce'])}}}"
        events.append(Event(t, "scenario", params))
        phases.append((t, name))
        t += min(rng.uniform(*cfg.scenario_period_s), total / 2)
        k += 1

    def scenario_at(time: float) -> str:
        return [name for start, name in phases if start <= time][-1]

    t = 1.0
    while t < total:
        scenario = scenario_at(t)
        if scenario == "tabletop" and rng.random() < cfg.grasp_share:
            events.append(Event(t, "grasp_goal", {"object_u": _r(rng.random())}))
        else:
            kinds = ("reachable", "unreachable", "inside_obstacle" if scenario == "tabletop" else "conveyor_target")
            w = np.asarray(cfg.goal_mix, dtype=float)
            kind = str(kinds[rng.choice(3, p=w / w.sum())])
            params: dict = {"goal": kind}
            if kind == "reachable":
                params.update(reachable_pose(rng, cfg))
            elif kind == "unreachable":
                params.update(unreachable_pose(rng, cfg))
            elif kind == "inside_obstacle":
                params.update(object_u=_r(rng.random()), surface=bool(rng.random() < 0.5))
            events.append(Event(t, "goal", params))
        t += rng.uniform(*cfg.goal_interval_s)

    def dropout(r):
        return {"duration_s": _r(r.uniform(*cfg.dropout_s))}

    def pause(r):
        return {"duration_s": _r(r.uniform(*cfg.pause_s))}

    def param(r):
        if r.random() < cfg.bad_param_share:
            name, value = BAD_PARAMS[int(r.integers(len(BAD_PARAMS)))]
            return {"name": name, "value": value, "expect": "refused"}
        names = sorted(GOOD_PARAMS)
        name = names[int(r.integers(len(names)))]
        return {"name": name, "value": _r(r.uniform(*GOOD_PARAMS[name])), "expect": "accepted"}

    def plan(r):
        tolerance = -1.0 if r.random() < cfg.bad_tolerance_share else 0.0
        return {**reachable_pose(r, cfg), "tolerance": tolerance}

    events += _periodic(rng, "camera_dropout", cfg.dropout_every_s, total, dropout)
    switches = np.array([e.t for e in events if e.kind == "scenario"])
    pauses = _periodic(rng, "joint_pause", cfg.pause_every_s, total, pause)
    events += [e for e in pauses if not spans_a_switch(e, switches)]
    events += _periodic(rng, "param_change", cfg.param_every_s, total, param)
    events += _periodic(rng, "plan_request", cfg.plan_every_s, total, plan)
    order = {k: i for i, k in enumerate(EVENT_KINDS)}
    return sorted(events, key=lambda e: (e.t, order[e.kind]))


def spans_a_switch(pause: Event, switches: np.ndarray, margin_s: float = 0.1) -> bool:
    """True if a scenario switch (times `switches` [s]) falls within the joint-state pause `pause` or margin_s [s]
    around it."""
    start, end = pause.t - margin_s, pause.t + float(pause.params["duration_s"]) + margin_s
    return bool(np.any((switches >= start) & (switches <= end)))


def counts(events: list[Event]) -> dict[str, int]:
    """Events per kind (every kind listed), and goals per goal kind as ``goal:<kind>``."""
    out = {k: sum(e.kind == k for e in events) for k in EVENT_KINDS}
    for g in GOAL_KINDS:
        out[f"goal:{g}"] = sum(e.kind == "goal" and e.params.get("goal") == g for e in events)
    return out


def down_quaternion(yaw: float) -> np.ndarray:
    """(4,) xyzw: the hand pointing down (TCP z along world -z), turned by yaw [rad] about world z."""
    c, s = np.cos(yaw / 2.0), np.sin(yaw / 2.0)
    return np.array([c, s, 0.0, 0.0])  # Rz(yaw) * Rx(pi)


def object_top_z(obj) -> float:
    """[m] the highest point of a scene object (sim_bridge.scenario.SceneObject) at its start pose."""
    from latent_planner_ros.robot.rotations import quat_to_matrix

    r = quat_to_matrix(np.asarray(obj.quaternion_xyzw, dtype=float)[None])[0]
    z = float(obj.position[2])
    if obj.type == "box":
        return z + float(np.abs(r[2]) @ np.asarray(obj.half_extents))
    if obj.type in ("cylinder", "capsule"):
        axis = abs(r[2, 2]) * obj.half_length
        radial = np.sqrt(max(0.0, 1.0 - r[2, 2] ** 2)) * obj.radius
        return z + axis + (obj.radius if obj.type == "capsule" else radial)
    if obj.type == "sphere":
        return z + float(obj.radius)
    if obj.vertices:
        return z + float(np.max((np.asarray(obj.vertices) @ r.T)[:, 2]))
    return z + obj.bounding_radius()


def still_objects(scenario) -> list:
    """The scenario's objects that do not move."""
    return [o for o in scenario.objects if o.motion is None]


HAND_HALF_OPENING_M = 0.04
"""[m] half the Panda hand's finger opening: a grasp target must be narrower, with GRASP_SPARE_M to spare a side."""
GRASP_SPARE_M = 0.01


def grasp_candidates(scenario) -> list[tuple]:
    """(object, yaw [rad]) of every still object the open hand can take from above: an upright box, cylinder or
    capsule, or a sphere, whose narrow horizontal half width leaves GRASP_SPARE_M to each finger; yaw turns the hand
    so the fingers close across that narrow side."""
    from latent_planner_ros.robot.rotations import quat_to_matrix

    out = []
    limit = HAND_HALF_OPENING_M - GRASP_SPARE_M
    for obj in still_objects(scenario):
        r = quat_to_matrix(np.asarray(obj.quaternion_xyzw, dtype=float)[None])[0]
        if obj.type == "sphere" and obj.radius <= limit:
            out.append((obj, 0.0))
        elif obj.type in ("cylinder", "capsule") and abs(r[2, 2]) > 0.99 and obj.radius <= limit:
            out.append((obj, 0.0))
        elif obj.type == "box":
            vertical = int(np.argmax(np.abs(r[2])))
            if abs(r[2, vertical]) < 0.99:
                continue
            sides = [i for i in range(3) if i != vertical]
            narrow = min(sides, key=lambda i: obj.half_extents[i])
            if obj.half_extents[narrow] <= limit:
                axis = r[:, narrow]  # the fingers close along the hand's y axis: (sin yaw, -cos yaw, 0)
                yaw = float(np.arctan2(axis[0], -axis[1]))
                out.append((obj, float((yaw + np.pi / 2) % np.pi - np.pi / 2)))  # the fingers are symmetric
    return out


def resolve_pose(event: Event, scenario) -> tuple[np.ndarray, np.ndarray] | None:
    """(position (3,) [m], quaternion (4,) xyzw) of a goal, grasp goal or plan request in `scenario` (a
    sim_bridge Scenario), or None for a conveyor_target goal or an object goal in a scene without a suitable object.

    inside_obstacle: the centre of a still object, or (surface) 5 mm under its top; grasp_goal: one of
    grasp_candidates, the TCP 2.5 cm under its top (at least 2.5 cm above the table), the hand pointing down with
    the fingers across the narrow side."""
    p = event.params
    if "position" in p:
        return np.asarray(p["position"], dtype=float), down_quaternion(p.get("yaw", 0.0))
    if "object_u" not in p:
        return None
    if event.kind == "grasp_goal":
        candidates = grasp_candidates(scenario)
        if not candidates:
            return None
        obj, yaw = candidates[min(int(p["object_u"] * len(candidates)), len(candidates) - 1)]
        z = max(object_top_z(obj) - 0.025, 0.025)
        return np.array([obj.position[0], obj.position[1], z]), down_quaternion(yaw)
    objects = still_objects(scenario)
    if not objects:
        return None
    obj = objects[min(int(p["object_u"] * len(objects)), len(objects) - 1)]
    centre = np.asarray(obj.position, dtype=float)
    z = object_top_z(obj) - 0.005 if p.get("surface") else centre[2]
    return np.array([centre[0], centre[1], z]), down_quaternion(0.0)

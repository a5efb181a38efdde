"""Reach to grasp: the same grasp semantics for every planner (AMP-LS and the OMPL baseline alike).

A grasp goal puts the TCP at an object with the open fingers around it. `plan_grasp`:

1. splits the target off the cloud (perception/grasp_target.py: the points between the fingers at the goal and
   the object they belong to, or a caller's radius / box);
2. with `approach_m` > 0, plans with the planner's own `plan` to the pre-grasp pose, `approach_m` back along the
   hand's z axis, on the WHOLE cloud: the target stays an obstacle there, since the hand must not hit the
   object before the approach;
3. then moves straight to the grasp pose (planning/grasp_approach.py), every step hard-checked by the planner's
   own check against the cloud without the target; a blocked approach is refused with where it was blocked.

With `approach_m` = 0 the planner plans straight to the grasp pose on the cloud without the target (nothing then
keeps the hand from sweeping through the object on the way: use an approach).

The result is one PlanResult over the joined path; its info carries "target_points" (points set aside),
"target" (the split's report), "approach" (what the approach did) and "transit" (the transit's reason).
"""

from __future__ import annotations

import threading
import time
from contextlib import nullcontext
from dataclasses import dataclass, field

import numpy as np

from latent_planner_ros.perception.grasp_target import GraspTargetConfig, TargetBox, split_target
from latent_planner_ros.planning.goal import Goal
from latent_planner_ros.planning.grasp_approach import ApproachConfig, segment_check_for, straight_approach
from latent_planner_ros.planning.result import PlanResult, result_from_path
from latent_planner_ros.robot.link_hulls import link_hull_planes, plane_distance
from latent_planner_ros.robot.panda import load_panda
from latent_planner_ros.robot.torch_fk import TorchFK

DEFAULT_APPROACH_M = 0.08
"""[m] pre-grasp distance back along the hand's z axis when a grasp problem names none"""


@dataclass(frozen=True)
class GraspConfig:
    target: GraspTargetConfig = field(default_factory=GraspTargetConfig)
    """how the target is found in the cloud"""
    approach: ApproachConfig = field(default_factory=ApproachConfig)
    """the straight approach's steps and IK"""


@dataclass(frozen=True)
class GraspSpec:
    """A goal marked as a grasp, as a caller gives it (the nodes' `grasp_pose`, `~/plan_grasp`, a scenario's
    `"grasp": true`): the pre-grasp distance and how the target is found."""

    approach_m: float = DEFAULT_APPROACH_M
    """[m] pre-grasp distance back along the hand's z axis (0: straight to the grasp, see plan_grasp)"""
    target_radius: float | None = None
    """[m] the target is every point within this of the TCP; None: found from the cloud"""
    target_box: TargetBox | None = None
    """the target is every point inside this box (not with target_radius)"""

    def __post_init__(self) -> None:
        if not (np.isfinite(self.approach_m) and self.approach_m >= 0):
            raise ValueError(f"approach_m must be a non-negative number of metres, got {self.approach_m!r}")
        r = self.target_radius
        if r is not None and not (np.isfinite(r) and r > 0):
            raise ValueError(f"target_radius must be a positive number of metres or None, got {r!r}")
        if r is not None and self.target_box is not None:
            raise ValueError("give a target radius or a target box, not both")

    def split(self, cloud: np.ndarray, goal: Goal, config: GraspTargetConfig | None = None):
        """The TargetSplit of cloud (N, 3) [m] at the grasp goal (perception/grasp_target.split_target)."""
        return split_target(cloud, goal.position, goal.rotation, config, self.target_radius, self.target_box)


def plan_grasp_spec(planner, start_q: np.ndarray, goal: Goal, cloud: np.ndarray, spec: GraspSpec) -> PlanResult:
    """plan_grasp with the approach and target of `spec` (cloud (N, 3) [m], no origins)."""
    return plan_grasp(
        planner, start_q, goal, cloud, None, spec.approach_m, target_radius=spec.target_radius,
        target_box=spec.target_box,
    )  # fmt: skip


def _exact_check(planner):
    """A context in which the planner's hard check is the exact geometric one (the learned backend's
    geometric_only), or nothing to change."""
    backend = getattr(planner, "backend", None)
    return backend.geometric_only() if backend is not None else nullcontext()


TOUCH_DEPTH_M = 0.003
"""[m] a target point counts as touched this far inside a link's hull: the depth camera's noise puts points of an
object the open fingers clear by a few millimetres up to 2 mm inside them (the generator's grasp configurations,
free on the true meshes, had noisy target points 1.8 mm deep)"""

_FK = threading.local()  # per thread: the node's service thread and its plan runner may both grasp


def target_touch(q_path: np.ndarray, target: np.ndarray) -> str:
    """ "" if no state of q_path (K, 7) [rad] has a target point (M, 3) [m] more than TOUCH_DEPTH_M inside one of
    its links' convex hulls, else why the grasp is refused: the target's points are set aside from the obstacles,
    so only this keeps the hand and fingers from closing on an object wider than the open hand, or off the centre
    of the fingers (points between the fingers are outside every hull and are fine)."""
    target = np.asarray(target, dtype=float).reshape(-1, 3)
    q_path = np.atleast_2d(np.asarray(q_path, dtype=float))
    if not len(target) or not len(q_path):
        return ""
    if getattr(_FK, "fk", None) is None:
        _FK.fk = TorchFK()
    frames = _FK.fk.frames_np(q_path)  # (K, F, 4, 4)
    for k in range(len(q_path)):
        for link, planes in link_hull_planes().items():
            rot, origin = frames[k, link, :3, :3], frames[k, link, :3, 3]
            if plane_distance(planes, (target - origin) @ rot).min() < -TOUCH_DEPTH_M:
                where = "at the grasp" if k == len(q_path) - 1 else f"{k + 1} of {len(q_path)} states into the approach"
                return (
                    f"grasp refused: the hand would touch the target {where} (an object wider than the open hand, or "
                    "off the centre of the fingers)"
                )
    return ""


def grasp_reason(result: PlanResult) -> str:
    """A grasp plan's reason with how many target points were set aside, for a caller (the nodes' plan
    results), e.g. "reached (grasp: 137 target points set aside)"."""
    return f"{result.reason} (grasp: {result.info.get('target_points', 0)} target points set aside)"


def pregrasp_goal(goal: Goal, approach_m: float) -> Goal:
    """The goal moved approach_m [m] back along the hand's z axis (same orientation and tolerances)."""
    return Goal(goal.position - approach_m * goal.rotation[:, 2], goal.rotation, goal.pos_tol, goal.ori_tol)


def _split_origin(origin: np.ndarray | None, keep: np.ndarray) -> np.ndarray | None:
    """Per-point origins (N, 3) follow the points kept (mask keep (N,)); a single origin (3,) stays."""
    if origin is None or np.ndim(origin) == 1:
        return origin
    return np.asarray(origin)[keep]


def plan_grasp(
    planner,
    start_q: np.ndarray,
    goal: Goal,
    cloud: np.ndarray,
    origin: np.ndarray | None = None,
    approach_m: float = DEFAULT_APPROACH_M,
    config: GraspConfig | None = None,
    target_radius: float | None = None,
    target_box: TargetBox | None = None,
) -> PlanResult:
    """Plan from start_q (7,) [rad] to the grasp `goal` with an AmpLs or an OmplPlanner (see the module
    docstring); cloud (N, 3) [m] in `world`, origin (3,) or (N, 3) [m] where it was seen from."""
    cfg = config or GraspConfig()
    if not (np.isfinite(approach_m) and approach_m >= 0):
        raise ValueError(f"approach_m must be a non-negative number of metres, got {approach_m!r}")
    t0 = time.perf_counter()
    split = split_target(cloud, goal.position, goal.rotation, cfg.target, target_radius, target_box)
    obstacles, obstacle_origin = split.obstacles, _split_origin(origin, ~split.mask)
    t_split = time.perf_counter() - t0
    info = {"target_points": split.count, "target": split.report, "approach_m": float(approach_m)}
    panda = load_panda()
    speed = float(getattr(planner.config, "speed_scale", 0.5))
    if approach_m <= 0:
        direct = planner.plan(start_q, goal, obstacles, obstacle_origin)
        info.update(direct.info, approach="none", transit=direct.reason)
        touch = target_touch(direct.q_path[-1:], split.target) if direct.success else ""
        return result_from_path(
            panda,
            direct.q_path,
            goal,
            solved=direct.success and not touch,
            reason=touch or direct.reason,
            t0=t0,
            speed_scale=speed,
            iterations=direct.iterations,
            timings={**direct.timings, "target_s": t_split},
            info=info,
        )
    transit = planner.plan(start_q, pregrasp_goal(goal, approach_m), cloud, origin)
    info.update(transit.info, transit=transit.reason)
    timings = {**{f"transit_{k}": v for k, v in transit.timings.items()}, "target_s": t_split}
    if not transit.success:
        info["approach"] = "not tried"
        return result_from_path(
            panda, transit.q_path, goal, solved=False, reason=f"pre-grasp: {transit.reason}", t0=t0,
            speed_scale=speed, iterations=transit.iterations, timings=timings, info=info,
        )  # fmt: skip
    t = time.perf_counter()
    check = segment_check_for(planner)
    with _exact_check(planner):  # the approach passes 1.5 cm from surfaces: the exact check decides, not a network
        check.set_cloud(obstacles, obstacle_origin)
        approach = straight_approach(panda, transit.q_path[-1], goal, check, cfg.approach)
    refused = approach.refused or target_touch(approach.q_path, split.target)
    timings["approach_s"] = time.perf_counter() - t
    info["approach"] = refused or f"{len(approach.q_path)} states, {approach_m * 100:g} cm"
    info["approach_states"] = 0 if refused else len(approach.q_path)  # the path's last states
    q_path = np.concatenate([transit.q_path, approach.q_path])
    return result_from_path(
        panda,
        q_path,
        goal,
        solved=not refused,
        reason=refused or "reached",
        t0=t0,
        speed_scale=speed,
        iterations=transit.iterations,
        timings=timings,
        info=info,
    )

"""The straight, checked Cartesian approach of a grasp, and the hard checks of the planners that it uses.

The approach moves the TCP on the straight line from where the transit ended (the pre-grasp pose) to the grasp
pose, orientation slerped, in steps of at most `step_m`: each state is an IK solution seeded from the previous
one, no joint may jump more than `max_joint_step_rad`, and every segment between states passes the planner's own
hard check against the obstacle cloud (the target set aside), so a refused approach names where it was blocked.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np
from scipy.spatial.transform import Rotation, Slerp

from latent_planner_ros.planning.goal import Goal
from latent_planner_ros.planning.ik import IkConfig, solve_ik
from latent_planner_ros.robot.panda import PandaModel


class SegmentCheck(Protocol):
    """A planner's hard check, pointed at a cloud."""

    def set_cloud(self, cloud: np.ndarray, origin: np.ndarray | None) -> None:
        """Check against cloud (N, 3) [m] seen from origin ((3,) or (N, 3) [m], or None)."""
        ...

    def segment_free(self, q_from: np.ndarray, q_to: np.ndarray) -> bool:
        """Whether the straight joint segment q_from (7,) -> q_to (7,) [rad] passes the check."""
        ...


class AmpLsCheck:
    """AMP-LS's hard check: its backend's scene and `segment_free` (backend check + exact self/table check)."""

    def __init__(self, planner):
        self.planner = planner

    def set_cloud(self, cloud: np.ndarray, origin: np.ndarray | None) -> None:
        self.planner.backend.set_scene(cloud, origin)

    def segment_free(self, q_from: np.ndarray, q_to: np.ndarray) -> bool:
        return bool(self.planner.segment_free(q_from, q_to))


class OmplCheck:
    """The OMPL baseline's state validity (occupancy map of the cloud at its resolution, self, table, limits),
    on states no farther apart than its motion validation resolution."""

    def __init__(self, planner):
        self.planner = planner

    def set_cloud(self, cloud: np.ndarray, origin: np.ndarray | None) -> None:
        from latent_planner_ros.planning.octree_checker import OccupancyMap

        cfg = self.planner.config
        self.planner.checker.set_occupancy(OccupancyMap.from_cloud(cloud, cfg.octree_resolution, cfg.min_z))

    def segment_free(self, q_from: np.ndarray, q_to: np.ndarray) -> bool:
        step = math.radians(self.planner.config.check_step_deg)
        k = max(1, math.ceil(float(np.linalg.norm(q_to - q_from)) / step))
        states = q_from + (q_to - q_from) * (np.arange(1, k + 1) / k)[:, None]
        return all(self.planner.checker.is_valid(q) for q in states)


def segment_check_for(planner) -> SegmentCheck:
    """The hard check of an AmpLs (has `segment_free`) or an OmplPlanner (has `checker.set_occupancy`)."""
    if hasattr(planner, "segment_free") and hasattr(planner, "backend"):
        return AmpLsCheck(planner)
    if hasattr(getattr(planner, "checker", None), "set_occupancy"):
        return OmplCheck(planner)
    raise TypeError(f"no hard check known for planner {type(planner).__name__}")


@dataclass(frozen=True)
class ApproachConfig:
    step_m: float = 0.005
    """[m] largest TCP step between approach states"""
    max_joint_step_rad: float = 0.1
    """[rad] an IK state farther than this (any joint) from the previous one refuses the approach"""
    ik: IkConfig = field(default_factory=lambda: IkConfig(max_iters=60, stall_iters=15, pos_tol=5e-4))
    """IK of each approach state (seeded from the previous one)"""


@dataclass(frozen=True)
class Approach:
    """The approach states (K, 7) [rad] after the first (excluded) and, when refused, why ("" = free)."""

    q_path: np.ndarray
    refused: str


def straight_approach(
    panda: PandaModel, q_from: np.ndarray, goal: Goal, check: SegmentCheck, config: ApproachConfig
) -> Approach:
    """Walk the TCP from its pose at q_from (7,) [rad] straight to `goal` (see the module docstring); `check`
    already points at the obstacle cloud."""
    start = panda.fk(q_from)
    p0, p1 = start.translation, np.asarray(goal.position, dtype=float)
    length = float(np.linalg.norm(p1 - p0))
    n = max(1, math.ceil(length / config.step_m))
    slerp = Slerp([0.0, 1.0], Rotation.from_matrix(np.stack([start.rotation, goal.rotation])))
    q, states = np.asarray(q_from, dtype=float), list[np.ndarray]()
    for k in range(1, n + 1):
        s = k / n
        where = f"{s * length * 100:.1f} of {length * 100:.1f} cm"
        sol = solve_ik(panda, Goal(p0 + s * (p1 - p0), slerp(s).as_matrix()), q, config.ik)
        if not sol.converged:
            return Approach(np.array(states).reshape(-1, 7), f"approach: no IK solution at {where}")
        if np.abs(sol.q - q).max() > config.max_joint_step_rad:
            return Approach(np.array(states).reshape(-1, 7), f"approach: the arm would jump at {where}")
        if not check.segment_free(q, sol.q):
            return Approach(np.array(states).reshape(-1, 7), f"approach blocked at {where} (target excluded)")
        q = sol.q
        states.append(q)
    return Approach(np.array(states).reshape(-1, 7), "")

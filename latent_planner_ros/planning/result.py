"""The result of a planning query, shared by every planner."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass(frozen=True)
class PlanResult:
    """A time-parameterised joint path and its end-effector path.

    Attributes:
        success: the goal was reached within tolerance by a path the planner believes collision-free.
        q_path: (T, 7) joint positions [rad], q_path[0] = start.
        times: (T,) time from start [s] respecting the joint velocity limits.
        ee_positions: (T, 3) TCP positions [m] (pinocchio FK of q_path).
        ee_quaternions: (T, 4) TCP orientations (x, y, z, w).
        planning_time_s: wall-clock planning time [s].
        reason: why it stopped ("reached", "step budget exhausted", "no progress", ...).
        final_pos_err_m, final_ori_err_rad: error of the last state to the goal.
        iterations: optimisation iterations (or planner-specific count).
        timings: named durations [s].
        info: planner-specific extras (loss terms, lambdas, ...).
    """

    success: bool
    q_path: np.ndarray
    times: np.ndarray
    ee_positions: np.ndarray
    ee_quaternions: np.ndarray
    planning_time_s: float
    reason: str
    final_pos_err_m: float = float("nan")
    final_ori_err_rad: float = float("nan")
    iterations: int = 0
    timings: dict = field(default_factory=dict)
    info: dict = field(default_factory=dict)

    @property
    def path_length_m(self) -> float:
        """Length of the end-effector path [m]."""
        return (
            float(np.linalg.norm(np.diff(self.ee_positions, axis=0), axis=1).sum())
            if len(self.ee_positions) > 1
            else 0.0
        )

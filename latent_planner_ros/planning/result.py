"""The result of a planning query, shared by every planner."""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np
import pinocchio as pin

from latent_planner_ros.planning.time_parameterisation import time_parameterise
from latent_planner_ros.robot.rotations import matrix_to_quat


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


def result_from_path(
    panda,
    q_path: np.ndarray,
    goal,
    *,
    solved: bool,
    reason: str,
    t0: float,
    speed_scale: float,
    iterations: int = 0,
    timings: dict | None = None,
    info: dict | None = None,
) -> PlanResult:
    """The PlanResult of a joint path a planner claims `solved` (or not), measured with the exact FK.

    panda: a PandaModel (pinocchio FK); q_path: (T, 7) [rad]; goal: a Goal; t0: time.perf_counter() at the start
    of planning [s]; speed_scale: fraction of the velocity limits for the time parameterisation. Success needs
    `solved` and the last state within the goal's tolerances; a solved path that ends outside them says by how much.
    """
    pos, rot = panda.fk_batch(q_path)
    pos_err = float(np.linalg.norm(pos[-1] - goal.position))
    ori_err = float(np.linalg.norm(pin.log3(rot[-1].T @ goal.rotation)))
    success = solved and pos_err <= goal.pos_tol and ori_err <= goal.ori_tol
    if solved and not success:
        reason = f"path ends {pos_err * 1000:.1f} mm, {np.degrees(ori_err):.1f} deg from the goal"
    elapsed = time.perf_counter() - t0
    return PlanResult(
        success=success,
        q_path=q_path,
        times=time_parameterise(q_path, speed_scale),
        ee_positions=pos,
        ee_quaternions=matrix_to_quat(rot),
        planning_time_s=elapsed,
        reason=reason,
        final_pos_err_m=pos_err,
        final_ori_err_rad=ori_err,
        iterations=iterations,
        timings={**(timings or {}), "total_s": elapsed},
        info=info or {},
    )

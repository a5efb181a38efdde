"""Inverse kinematics of the TCP by damped least squares (pinocchio), and goal configurations from many seeds.

`solve_ik` runs DLS on the SE(3) log error of one seed; `goal_configurations` runs it from several seeds
(the start, the ready pose, then uniform samples within the joint limits) and keeps distinct solutions that
a validity function accepts. This is how the OMPL baseline turns a goal pose into joint-space goal states.

A goal whose orientation tolerance is at least pi accepts every orientation (LSPP's position-only goals):
then DLS runs on the position error alone, with the 3-row position Jacobian, and only the position converges.
"""

from __future__ import annotations

import math
import time
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
import pinocchio as pin

from latent_planner_ros.planning.goal import Goal
from latent_planner_ros.robot.limits import Q_MAX, Q_MIN, Q_READY
from latent_planner_ros.robot.panda import EE_FRAME, PandaModel


@dataclass
class IkConfig:
    """Damped-least-squares IK; every field maps 1:1 onto a ROS parameter (prefix ``ompl.ik.``)."""

    n_seeds: int = 16
    """seeds tried at most: the start, the ready pose, then uniform samples within the joint limits"""
    max_solutions: int = 4
    """stop once this many distinct valid solutions are found"""
    max_iters: int = 150
    """DLS iterations per seed"""
    damping: float = 1e-4
    """Levenberg damping added to J J^T"""
    max_step_rad: float = 0.5
    """largest joint change of one iteration [rad]"""
    pos_tol: float = 1e-3
    """convergence: position error [m] (also capped at half the goal's tolerance)"""
    ori_tol_deg: float = 0.5
    """convergence: orientation error [deg] (also capped at half the goal's tolerance)"""
    min_separation_rad: float = 0.1
    """solutions closer than this (max joint difference) [rad] to a kept one are duplicates"""
    timeout_s: float = 1.0
    """wall-clock budget of the whole multi-seed search [s]"""
    stall_iters: int = 0
    """give a seed up (unconverged) once neither its position nor its orientation error has dropped below 0.99 of
    its best for this many iterations (stuck at a joint limit or a local minimum); 0: run max_iters"""

    def __post_init__(self) -> None:
        for name in ("n_seeds", "max_solutions", "max_iters"):
            v = getattr(self, name)
            if not (isinstance(v, int) and not isinstance(v, bool) and v >= 1):
                raise ValueError(f"ik.{name} must be an integer >= 1, got {v!r}")
        v = self.stall_iters
        if not (isinstance(v, int) and not isinstance(v, bool) and v >= 0):
            raise ValueError(f"ik.stall_iters must be an integer >= 0, got {v!r}")
        for name in ("damping", "max_step_rad", "pos_tol", "ori_tol_deg", "min_separation_rad", "timeout_s"):
            v = getattr(self, name)
            if not (isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v) and v > 0):
                raise ValueError(f"ik.{name} must be a positive finite number, got {v!r}")


@dataclass(frozen=True)
class IkSolution:
    """One DLS run: the final q (7,) [rad], its errors [m], [rad], iterations, and whether it converged."""

    q: np.ndarray
    pos_err: float
    ori_err: float
    iterations: int
    converged: bool


@dataclass
class IkSearch:
    """The outcome of a multi-seed search.

    Attributes:
        solutions: distinct valid goal configurations (each (7,) [rad]), in the order found.
        attempts: seeds tried.
        converged: seeds whose DLS converged.
        rejected: why converged solutions were refused, reason -> count.
        best_pos_err, best_ori_err: smallest errors [m], [rad] over all seeds (to explain a failure).
        elapsed_s: wall-clock time [s].
    """

    solutions: list[np.ndarray] = field(default_factory=list)
    attempts: int = 0
    converged: int = 0
    rejected: Counter = field(default_factory=Counter)
    best_pos_err: float = math.inf
    best_ori_err: float = math.inf
    elapsed_s: float = 0.0

    def failure_reason(self) -> str:
        """Why no goal configuration was found (empty when some were)."""
        if self.solutions:
            return ""
        if self.converged == 0:
            return (
                f"no IK solution: none of {self.attempts} seeds converged (best {self.best_pos_err * 1000:.0f} mm, "
                f"{math.degrees(self.best_ori_err):.0f} deg from the goal pose)"
            )
        causes = ", ".join(f"{n} {why}" for why, n in self.rejected.most_common())
        return f"no valid IK solution: all {self.converged} IK solutions are invalid ({causes})"


def is_position_only(goal: Goal) -> bool:
    """True if the goal accepts any orientation (ori_tol >= pi [rad], the largest rotation angle)."""
    return goal.ori_tol >= math.pi


def solve_ik(panda: PandaModel, goal: Goal, q0: np.ndarray, config: IkConfig, frame: str = EE_FRAME) -> IkSolution:
    """DLS from q0 (7,) [rad] towards goal's pose of `frame` (its position only if `is_position_only(goal)`);
    q stays within the joint limits. ori_err [rad] is reported in both cases."""
    position_only = is_position_only(goal)
    model = panda.model
    data = model.createData()
    fid = panda.frame_id(frame)
    target = pin.SE3(np.asarray(goal.rotation, dtype=float), np.asarray(goal.position, dtype=float))
    target_p = target.translation
    pos_tol = min(config.pos_tol, 0.5 * goal.pos_tol)
    ori_tol = min(math.radians(config.ori_tol_deg), 0.5 * goal.ori_tol)
    damping = config.damping * np.eye(3 if position_only else 6)
    q = np.minimum(np.maximum(np.asarray(q0, dtype=float), Q_MIN), Q_MAX)
    pos_err = math.inf
    best_pos, best_ori, best_it = math.inf, math.inf, 0
    for it in range(config.max_iters + 1):
        pin.framesForwardKinematics(model, data, q)
        current = data.oMf[fid]
        d = target_p - current.translation
        pos_err = math.sqrt(float(d @ d))
        ori_err = 0.0
        if position_only:
            if pos_err < pos_tol:
                return IkSolution(q, pos_err, _angle(current, target), it, True)
        else:
            err_se3 = current.actInv(target)  # target seen from the current frame
            err = pin.log6(err_se3).vector  # (linear, angular); |angular| is the rotation angle to the target
            w = err[3:]
            ori_err = math.sqrt(float(w @ w))
            if pos_err < pos_tol and ori_err < ori_tol:
                return IkSolution(q, pos_err, _angle(current, target), it, True)
        if pos_err < 0.99 * best_pos or ori_err < 0.99 * best_ori:
            best_it = it
        best_pos, best_ori = min(best_pos, pos_err), min(best_ori, ori_err)
        if it == config.max_iters or (config.stall_iters and it - best_it >= config.stall_iters):
            break
        if position_only:
            err = d
            jac = pin.computeFrameJacobian(model, data, q, fid, pin.LOCAL_WORLD_ALIGNED)[:3]
        else:
            jac = pin.Jlog6(err_se3.inverse()) @ pin.computeFrameJacobian(model, data, q, fid, pin.LOCAL)
        try:
            dq = jac.T @ np.linalg.solve(jac @ jac.T + damping, err)
        except np.linalg.LinAlgError:  # a goal so far off (1e308 m) that the error and Jacobian are not finite
            break
        if not np.all(np.isfinite(dq)):
            break
        biggest = float(np.abs(dq).max())
        if biggest > config.max_step_rad:
            dq *= config.max_step_rad / biggest
        q = np.minimum(np.maximum(q + dq, Q_MIN), Q_MAX)
    return IkSolution(q, pos_err, _angle(data.oMf[fid], target), it, False)


def _angle(current: pin.SE3, target: pin.SE3) -> float:
    """Rotation angle [rad] between two poses' orientations."""
    return float(np.linalg.norm(pin.log3(current.rotation.T @ target.rotation)))


def goal_configurations(
    panda: PandaModel,
    goal: Goal,
    start_q: np.ndarray,
    invalid_reason: Callable[[np.ndarray], str | None],
    config: IkConfig,
    rng: np.random.Generator,
) -> IkSearch:
    """Distinct valid IK solutions of `goal` (see IkConfig), seeded from start_q (7,) [rad] first.

    invalid_reason(q) returns None for an acceptable configuration, else a short reason (counted in the
    search's `rejected`).
    """
    t0 = time.perf_counter()
    out = IkSearch()
    ori_weight = 0.0 if is_position_only(goal) else 1.0  # ranks seeds for the failure report
    best = math.inf
    seeds = [np.asarray(start_q, dtype=float), Q_READY]
    for i in range(config.n_seeds):
        if time.perf_counter() - t0 > config.timeout_s or len(out.solutions) >= config.max_solutions:
            break
        seed = seeds[i] if i < len(seeds) else rng.uniform(Q_MIN, Q_MAX)
        sol = solve_ik(panda, goal, seed, config)
        out.attempts += 1
        if sol.pos_err + ori_weight * sol.ori_err < best:
            best = sol.pos_err + ori_weight * sol.ori_err
            out.best_pos_err, out.best_ori_err = sol.pos_err, sol.ori_err
        if not sol.converged:
            continue
        out.converged += 1
        if any(np.abs(sol.q - s).max() < config.min_separation_rad for s in out.solutions):
            continue
        why = invalid_reason(sol.q)
        if why is None:
            out.solutions.append(sol.q)
        else:
            out.rejected[why] += 1
    out.elapsed_s = time.perf_counter() - t0
    return out

"""Static reach through the graph: one plan call and its execution in the sim, and what they measure. No ROS.

Success: the planner returned a plan, and after executing it the sim's TCP is within `pos_tol_m` and
`ori_tol_deg` of the goal with no contact between the arm and the scenario objects at any time.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from latent_planner_ros.evaluation.trial import contact_events
from latent_planner_ros.robot.rotations import quat_to_matrix

POS_TOL_M = 0.02
"""[m] final TCP position error of a success (the plan's 1 cm tolerance plus the sim's tracking error)."""
ORI_TOL_DEG = 20.0
"""[deg] final TCP orientation error of a success (the plan's 15 deg plus tracking)."""


@dataclass(frozen=True)
class PlanCall:
    """The answer of one GetPlan call.

    Attributes:
        planner: the node's name; planned: a non-empty path came back; plan_s: the call's wall-clock time [s].
        ee_path: (N, 3) planned TCP positions [m]; q_path: (T, 7) the joint trajectory [rad]; times: (T,) [s].
        reason: why no plan came back (the node's status), "" otherwise.
    """

    planner: str
    planned: bool
    plan_s: float
    ee_path: np.ndarray
    q_path: np.ndarray
    times: np.ndarray
    reason: str = ""


@dataclass(frozen=True)
class ExecutionLog:
    """The sim's state while a plan was executed; times [s] of simulated time from the execution's start.

    Attributes:
        t, q: (N,) and (N, 7) joint states [rad]; distance_t, distance: (M,) the arm's clearance to the
        objects [m]; contact_t, contact: (K,) arm-object contact flags.
    """

    t: np.ndarray
    q: np.ndarray
    distance_t: np.ndarray
    distance: np.ndarray
    contact_t: np.ndarray
    contact: np.ndarray

    @classmethod
    def from_rows(cls, rows: dict[str, list]) -> ExecutionLog:
        """From {"joints": [(t, q)], "distance": [(t, d)], "contact": [(t, flag)]} (absolute times)."""
        joints = rows["joints"]
        t0 = joints[0][0] if joints else 0.0

        def col(name, k, dtype=float):
            return np.array([r[k] for r in rows[name]], dtype=dtype)

        return cls(
            t=col("joints", 0) - t0 if joints else np.zeros(0),
            q=col("joints", 1).reshape(-1, 7),
            distance_t=col("distance", 0) - t0 if rows["distance"] else np.zeros(0),
            distance=col("distance", 1),
            contact_t=col("contact", 0) - t0 if rows["contact"] else np.zeros(0),
            contact=col("contact", 1, bool),
        )


def path_length(points: np.ndarray) -> float:
    """Summed Euclidean step length of a path (N, D) (0 for fewer than two points)."""
    points = np.asarray(points, dtype=float)
    return float(np.linalg.norm(np.diff(points, axis=0), axis=1).sum()) if len(points) > 1 else 0.0


def reach_metrics(
    call: PlanCall,
    log: ExecutionLog | None,
    goal_position: np.ndarray,
    goal_quaternion_xyzw: np.ndarray,
    pos_tol_m: float = POS_TOL_M,
    ori_tol_deg: float = ORI_TOL_DEG,
) -> dict:
    """The figures of one plan call and its execution (log None: nothing was executed)."""
    from latent_planner_ros.robot.panda import load_panda

    row = {
        "planner": call.planner,
        "planned": call.planned,
        "reason": call.reason,
        "plan_s": round(call.plan_s, 4),
        "planned_tcp_path_m": path_length(call.ee_path) if call.planned else None,
        "planned_joint_path_rad": path_length(call.q_path) if call.planned else None,
        "trajectory_s": float(call.times[-1]) if call.planned else None,
    }
    empty = {"final_pos_err_m": None, "final_ori_err_deg": None, "min_distance_m": None, "contacts": 0}
    if log is None or not len(log.q):
        return {**row, **empty, "executed_s": None, "tcp_path_m": None, "joint_path_rad": None, "success": False}
    pos, rot = load_panda().fk_batch(log.q)
    goal_rot = quat_to_matrix(np.asarray(goal_quaternion_xyzw, dtype=float))
    cos = np.clip((np.trace(goal_rot.T @ rot[-1]) - 1.0) / 2.0, -1.0, 1.0)
    pos_err = float(np.linalg.norm(pos[-1] - goal_position))
    ori_err = float(np.degrees(np.arccos(cos)))
    contacts = contact_events(log.contact)
    row.update(
        executed_s=float(log.t[-1]),
        tcp_path_m=path_length(pos),
        joint_path_rad=path_length(log.q),
        final_pos_err_m=pos_err,
        final_ori_err_deg=ori_err,
        min_distance_m=float(log.distance.min()) if log.distance.size else None,
        contacts=contacts,
        success=bool(call.planned and pos_err <= pos_tol_m and ori_err <= ori_tol_deg and contacts == 0),
    )
    return row


def summarise(rows: list[dict]) -> dict:
    """Per planner: runs, successes, median plan time [s], median executed TCP path [m], min clearance [m]."""
    out = {}
    for planner in dict.fromkeys(r["planner"] for r in rows):
        mine = [r for r in rows if r["planner"] == planner]
        done = [r for r in mine if r["planned"]]
        dists = [r["min_distance_m"] for r in mine if r["min_distance_m"] is not None]
        out[planner] = {
            "runs": len(mine),
            "planned": len(done),
            "successes": sum(r["success"] for r in mine),
            "contacts": sum(r["contacts"] for r in mine),
            "plan_s_median": float(np.median([r["plan_s"] for r in mine])) if mine else None,
            "tcp_path_m_median": float(np.median([r["tcp_path_m"] for r in done])) if done else None,
            "min_distance_m": float(min(dists)) if dists else None,
        }
    return out

"""The artificial potential field baseline of LSPP mode (seed chapter 6 V-B, adapted from Flacco et al. [38]).

A local reactive method with direct access to the obstacles (upright cylinders o = (x, y, h, r)). Every step
of `dt` seconds:
  1. attraction: the TCP position error e gives a TCP velocity k e (capped), mapped to joint space by the
     damped pseudo-inverse of the TCP position Jacobian (orientation is free: LSPP's goals are positions);
  2. repulsion: the arm is covered by the spheres of `robot.spheres`; for each link and each obstacle (and the
     table plane) the link's sphere of least clearance d, if d < rho, gets a velocity away from the obstacle of
     magnitude v_max / (1 + exp((2 d / rho - 1) alpha)) [38], mapped to joint space by the damped
     pseudo-inverse of that sphere centre's position Jacobian; likewise (within self_influence) the closest
     spheres of every link pair that may collide are pushed apart through their relative Jacobian;
  3. joint limits: joints within a margin of a limit are pushed back in the null space of the TCP Jacobian;
     the joint velocity is scaled to a fraction of V_MAX and q is clipped into the limits;
  4. the new state is checked exactly (self, table, obstacles); planning stops when the TCP is within the
     goal's position tolerance, on a collision, when the error stalls (a local minimum) or after max_steps.

    planner = PotentialFieldPlanner(PotentialFieldConfig())
    planner.set_cylinders(o)                 # (K, 4) rows (x, y, h, r) [m]
    result = planner.plan(start_q, goal)     # a PlanResult; a cloud, if passed, is ignored
"""

from __future__ import annotations

import time

import numpy as np
import pinocchio as pin

from latent_planner_ros.data.cylinders import cylinder_scene, validate_cylinders
from latent_planner_ros.planning.cylinder_distance import cylinder_distance
from latent_planner_ros.planning.goal import Goal
from latent_planner_ros.planning.potential_field_config import PotentialFieldConfig
from latent_planner_ros.planning.result import PlanResult, result_from_path
from latent_planner_ros.planning.scene_checker import SceneChecker
from latent_planner_ros.robot.limits import Q_MAX, Q_MIN, V_MAX
from latent_planner_ros.robot.panda import EE_FRAME, LINK_FRAMES, PandaModel, load_panda
from latent_planner_ros.robot.spheres import panda_spheres

REACH_FRACTION = 0.5
"""Planning stops once the TCP is within this fraction of the goal's position tolerance."""


def _skew(v: np.ndarray) -> np.ndarray:
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


def _dls(jac: np.ndarray, damping: float) -> np.ndarray:
    """Damped pseudo-inverse (7, m) of a Jacobian (m, 7)."""
    return jac.T @ np.linalg.inv(jac @ jac.T + damping * np.eye(len(jac)))


class PotentialFieldPlanner:
    """Jacobian pseudo-inverse reaching with repulsion from known upright cylinders and the table.

    Satisfies the planner protocol (`name`, `plan(start_q, goal, cloud=None)`); the obstacles are given
    beforehand with `set_cylinders` (or the constructor). Not thread-safe (holds pinocchio Data).

    Args:
        config: gains and budgets (see PotentialFieldConfig).
        panda: the pinocchio model (default: the shared one).
        cylinders: (K, 4) rows (x, y, h, r) [m] (default: none).
    """

    name = "potential_field"

    def __init__(
        self,
        config: PotentialFieldConfig | None = None,
        panda: PandaModel | None = None,
        cylinders: np.ndarray | None = None,
    ):
        self.config = config or PotentialFieldConfig()
        self.panda = panda or load_panda()
        self._data = self.panda.model.createData()
        self._tcp = self.panda.frame_id(EE_FRAME)
        self.spheres = panda_spheres()
        self._moving = np.flatnonzero(self.spheres.link != LINK_FRAMES.index("panda_link0"))
        self._link_fid = {k: self.panda.frame_id(LINK_FRAMES[k]) for k in np.unique(self.spheres.link)}
        pair_links = self.spheres.link[self.spheres.self_pairs]  # (P, 2)
        self._pair_key = pair_links[:, 0] * len(LINK_FRAMES) + pair_links[:, 1]
        self.checker = SceneChecker(table=self.config.table, panda=self.panda)
        self.set_cylinders(np.zeros((0, 4)) if cylinders is None else cylinders)

    def set_cylinders(self, cylinders: np.ndarray) -> None:
        """Plan around upright cylinders (K, 4), rows (x, y, h, r) [m], from the next `plan` on."""
        self.cylinders = validate_cylinders(cylinders)
        self.checker.set_scene(cylinder_scene(self.cylinders))

    # -- one step -------------------------------------------------------------------------------------------
    def _speed(self, clearance: float, influence: float) -> float:
        """Repulsive speed [m/s] at a clearance [m] ([38]'s logistic profile)."""
        return self.config.repulsive_speed / (1.0 + np.exp((2.0 * clearance / influence - 1.0) * self.config.shape))

    def _point_jacobian(self, s: int, centres: np.ndarray, poses: dict, jacobians: dict) -> np.ndarray:
        """Position Jacobian (3, 7) of sphere s's centre, from its link frame's (6, 7) Jacobian."""
        k = self.spheres.link[s]
        jac = jacobians[k]
        return jac[:3] - _skew(centres[s] - poses[k].translation) @ jac[3:]

    def _obstacle_repulsion(self, centres: np.ndarray, poses: dict, jacobians: dict) -> tuple[np.ndarray, float]:
        """Joint velocity (7,) [rad/s] away from the cylinders and the table, and the least clearance [m]."""
        cfg = self.config
        moving = self._moving
        dist, direction = cylinder_distance(centres[moving], self.cylinders)  # (S, K), (S, K, 3)
        if cfg.table:
            dist = np.concatenate([dist, centres[moving, 2:3]], axis=1)
            up = np.broadcast_to([0.0, 0.0, 1.0], (len(moving), 1, 3))
            direction = np.concatenate([direction, up], axis=1)
        clearance = dist - self.spheres.radius[moving, None]  # (S, K')
        dq = np.zeros(7)
        least = float(clearance.min()) if clearance.size else float("inf")
        if least >= cfg.influence:
            return dq, least
        links = self.spheres.link[moving]
        for k in np.unique(links):
            rows = np.flatnonzero(links == k)
            for o in np.flatnonzero(clearance[rows].min(axis=0) < cfg.influence):
                s = rows[np.argmin(clearance[rows, o])]
                jac = self._point_jacobian(moving[s], centres, poses, jacobians)
                v = self._speed(clearance[s, o], cfg.influence) * direction[s, o]
                dq += _dls(jac, cfg.damping) @ v
        return dq, least

    def _self_repulsion(self, centres: np.ndarray, poses: dict, jacobians: dict) -> np.ndarray:
        """Joint velocity (7,) [rad/s] separating the closest sphere pair of every link pair that may collide."""
        cfg = self.config
        if cfg.self_influence <= 0:
            return np.zeros(7)
        i, j = self.spheres.self_pairs.T
        diff = centres[i] - centres[j]
        dist = np.linalg.norm(diff, axis=1)
        clearance = dist - self.spheres.radius[i] - self.spheres.radius[j]
        active = np.flatnonzero(clearance < cfg.self_influence)
        dq = np.zeros(7)
        for key in np.unique(self._pair_key[active]):
            rows = active[self._pair_key[active] == key]
            p = rows[np.argmin(clearance[rows])]
            jac = self._point_jacobian(i[p], centres, poses, jacobians)
            jac = jac - self._point_jacobian(j[p], centres, poses, jacobians)
            v = self._speed(clearance[p], cfg.self_influence) * diff[p] / max(dist[p], 1e-9)
            dq += _dls(jac, cfg.damping) @ v
        return dq

    def _limit_velocity(self, q: np.ndarray) -> np.ndarray:
        """Joint velocity (7,) [rad/s] pushing joints within limit_margin of a limit back towards the range."""
        m = self.config.limit_margin
        low = np.clip((Q_MIN + m - q) / m, 0.0, 1.0)
        high = np.clip((q - (Q_MAX - m)) / m, 0.0, 1.0)
        return self.config.limit_gain * (low - high)

    def _step(self, q: np.ndarray, goal: Goal) -> tuple[np.ndarray, float, float]:
        """Joint velocity (7,) [rad/s] at q (7,) [rad], the TCP position error [m] and the least clearance [m]."""
        cfg = self.config
        model, data = self.panda.model, self._data
        pin.computeJointJacobians(model, data, q)
        pin.updateFramePlacements(model, data)
        frame = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED
        err = goal.position - data.oMf[self._tcp].translation
        dist = float(np.linalg.norm(err))
        v_att = cfg.attractive_gain * err
        speed = float(np.linalg.norm(v_att))
        if speed > cfg.max_ee_speed:
            v_att *= cfg.max_ee_speed / speed
        jac_tcp = pin.getFrameJacobian(model, data, self._tcp, frame)[:3]
        pinv_tcp = _dls(jac_tcp, cfg.damping)
        poses = {k: data.oMf[fid] for k, fid in self._link_fid.items()}
        jacobians = {k: pin.getFrameJacobian(model, data, fid, frame) for k, fid in self._link_fid.items()}
        rot = np.stack([poses[k].rotation for k in self.spheres.link])
        trans = np.stack([poses[k].translation for k in self.spheres.link])
        centres = np.einsum("sij,sj->si", rot, self.spheres.centre) + trans  # (S, 3) [m]
        dq_rep, least = self._obstacle_repulsion(centres, poses, jacobians)
        dq_rep += self._self_repulsion(centres, poses, jacobians)
        null = np.eye(7) - pinv_tcp @ jac_tcp
        dq = pinv_tcp @ v_att + dq_rep + null @ self._limit_velocity(q)
        scale = float(np.max(np.abs(dq) / (cfg.joint_speed_scale * V_MAX)))
        return (dq / scale if scale > 1.0 else dq), dist, least

    # -- planning -------------------------------------------------------------------------------------------
    def plan(
        self, start_q: np.ndarray, goal: Goal, cloud: np.ndarray | None = None, origin: np.ndarray | None = None
    ) -> PlanResult:
        """Move from start_q (7,) [rad] towards goal.position [m]; `cloud` and `origin` are ignored (the obstacles
        are known).

        Raises:
            ValueError: start_q is not 7 finite numbers (a caller's bug; planning failures return a result).
        """
        cfg = self.config
        t0 = time.perf_counter()
        q = np.asarray(start_q, dtype=float)
        if q.shape != (7,) or not np.all(np.isfinite(q)):
            raise ValueError(f"start_q must be 7 finite joint positions, got {start_q!r}")
        q = q.copy()
        path = [q.copy()]
        self.checker.checks = 0
        reach = REACH_FRACTION * goal.pos_tol
        best, best_step, least = np.inf, 0, np.inf
        reason = "step budget exhausted"
        why = self.checker.invalid_reason(np.clip(q, Q_MIN, Q_MAX)) if cfg.check_collisions else None
        steps = 0
        if why is not None:
            reason = f"start state invalid: {why}"
        else:
            for steps in range(cfg.max_steps + 1):
                dq, dist, clearance = self._step(q, goal)
                least = min(least, clearance)
                if dist <= reach:
                    reason = "reached"
                    break
                if dist < best - cfg.stall_progress:
                    best, best_step = dist, steps
                elif steps - best_step >= cfg.stall_steps:
                    reason = f"no progress for {cfg.stall_steps} steps (local minimum)"
                    break
                if steps == cfg.max_steps:
                    break
                q = np.clip(q + cfg.dt * dq, Q_MIN, Q_MAX)
                why = self.checker.invalid_reason(q) if cfg.check_collisions else None
                if why is not None:
                    reason = f"collision: {why}"
                    break
                path.append(q.copy())
        info = {
            "min_sphere_clearance_m": least,
            "obstacles": len(self.cylinders),
            "collision_checks": self.checker.checks,
        }
        return self._result(np.stack(path), goal, reason, t0, steps, info)

    def _result(self, q_path: np.ndarray, goal: Goal, reason: str, t0: float, steps: int, info: dict) -> PlanResult:
        return result_from_path(
            self.panda,
            q_path,
            goal,
            solved=reason == "reached",
            reason=reason,
            t0=t0,
            speed_scale=self.config.speed_scale,
            iterations=steps,
            info=info,
        )

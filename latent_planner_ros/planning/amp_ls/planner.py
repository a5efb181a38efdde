"""AMP-LS: reaching by activation maximisation in the latent space of the robot-state VAE.

Seed chapter 7, Algorithm 1: z_0 encodes the start state; every step decodes z_t, and if the decoded state's
collision probability is below gamma_col, the linear interpolation from the last accepted state is checked
explicitly. A colliding interpolation scales lambda_pos and lambda_ori by i/m and back-traces z to the last
accepted latent; a free one is appended to the path. The loss weights are adapted by GECO (appendix 6.B.1) and
z takes one optimiser step on

    L = lambda_pos |e_pos - target_pos| + lambda_ori |e_ori - target_ori| + lambda_col (-log(1 - p_col))
        + (-log p(z)).

`plan` runs this open loop; `step` runs it one tick at a time for closed-loop control, keeping z and the
multipliers across ticks and accepting a new goal and scene at every tick.

The planner is composed of parts, each built from its sub-configuration (config.py; None = off):
- `search.LatentSearch`: the latent seeds (search.n_seeds) and their restarts;
- `checker.SegmentChecker`: the hard check of interpolated steps, the start's escape, lazy verification;
- `finish.StraightFirst`, `finish.ExactFinish`, `finish.GoalGuidance`: finishing by checked straight segments;
- `escape_part.RrtEscapePart`: RRTConnect on the same hard check when the latent search stalls.
"""

from __future__ import annotations

import time
from contextlib import nullcontext
from dataclasses import replace

import numpy as np
import torch

from latent_planner_ros.models.vae import RobotStateVAE
from latent_planner_ros.planning.amp_ls.checker import SegmentChecker
from latent_planner_ros.planning.amp_ls.config import AmpLsConfig
from latent_planner_ros.planning.amp_ls.escape_part import RrtEscapePart
from latent_planner_ros.planning.amp_ls.finish import ExactFinish, GoalGuidance, StraightFirst
from latent_planner_ros.planning.amp_ls.search import LatentSearch, StepResult
from latent_planner_ros.planning.collision_backend import CollisionBackend
from latent_planner_ros.planning.goal import Goal
from latent_planner_ros.planning.plan_clock import PlanClock
from latent_planner_ros.planning.result import PlanResult
from latent_planner_ros.planning.shortcut import shortcut
from latent_planner_ros.planning.time_parameterisation import interpolate, time_parameterise
from latent_planner_ros.robot.collision import CollisionChecker
from latent_planner_ros.robot.limits import Q_MAX, Q_MIN, Q_READY, V_MAX
from latent_planner_ros.robot.panda import load_panda
from latent_planner_ros.robot.rotations import matrix_to_quat, matrix_to_rot6d, rot6d_to_matrix, rotation_angle_between
from latent_planner_ros.robot.state import robot_state
from latent_planner_ros.robot.torch_fk import TorchFK


class AmpLs:
    """The AMP-LS planner over a frozen VAE and a collision backend.

    Args:
        vae: the robot-state VAE (eval mode; its weights are not changed).
        backend: collision backend used for the collision loss and the explicit checks.
        config: planner configuration (setting `config` later rebuilds the parts).
        seed: seed of the planner's own torch generator (extra latent seeds).
    """

    name = "amp_ls"

    def __init__(self, vae: RobotStateVAE, backend: CollisionBackend, config: AmpLsConfig | None = None, seed: int = 0):
        self.vae = vae.eval()
        for p in self.vae.parameters():
            p.requires_grad_(False)
        self.backend = backend
        self.generator = torch.Generator().manual_seed(seed)
        self.fk64 = TorchFK(dtype=torch.float64)
        self.panda = load_panda()
        self.clock = PlanClock()  # where `plan`'s time goes (PlanResult.timings)
        self._robot_checker = CollisionChecker(convex=True)
        self._search: LatentSearch | None = None  # the closed loop's search, kept across ticks
        self._eyes: np.ndarray | None = None  # the current plan's camera centres (K, 3) [m], if given
        self.config = config or AmpLsConfig()

    @property
    def config(self) -> AmpLsConfig:
        """The configuration; setting it rebuilds the parts."""
        return self._config

    @config.setter
    def config(self, config: AmpLsConfig) -> None:
        self._config = config
        self.segments = SegmentChecker(self.backend, config, self.clock, self._robot_checker)
        self.straight = StraightFirst(self.segments) if config.plan.shortcut else None
        lazy = config.checks.lazy
        self.finisher = (
            None
            if config.finish is None
            else ExactFinish(config.finish, self.panda, self.segments, self.clock, self.straight, lazy)
        )
        self.guidance = (
            None
            if config.guidance is None
            else GoalGuidance(config.guidance, self.panda, self.segments, self.clock, self.generator)
        )
        self.escape = (
            None
            if config.escape is None
            else RrtEscapePart(config.escape, self.panda, self.segments, self.clock, self.generator)
        )

    @property
    def checker(self) -> CollisionChecker:
        """The exact self- and table-collision checker of the hard check (checks.self_check)."""
        return self._robot_checker

    @checker.setter
    def checker(self, checker: CollisionChecker) -> None:
        self._robot_checker = self.segments.robot = checker

    def new_search(self, start_q: np.ndarray, n_seeds: int | None = None, lr: float | None = None) -> LatentSearch:
        """A latent search from start_q (7,) [rad] with this planner's VAE, configuration and generator."""
        return LatentSearch(self.vae, self.config, self.generator, start_q, n_seeds, lr)

    # -- Algorithm 1 -----------------------------------------------------------------------------------
    def decode(self, z: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor, torch.Tensor]:
        """Decoded q (B, 7), TCP position (B, 3) and 6D orientation (B, 6) used by the target losses, and
        p(collision) (B,), all differentiable in z (B, L). With the kinematic decoder, one FK of every link frame
        gives the TCP pose and, to a backend that takes link frames (the learned one), the collision network's
        link poses."""
        cfg = self.config
        frames = None
        if self.vae.config.decoder == "kinematic":
            q = self.vae.decode_q(z)
            frames = self.vae.fk(q)  # (B, len(LINK_FRAMES), 4, 4)
            tcp = frames[:, self.vae.fk.ee_index]
            pos, ori = tcp[:, :3, 3], matrix_to_rot6d(tcp[:, :3, :3])
        else:
            dec = self.vae.decode(z)
            q, pos, ori = dec.q, dec.pos, dec.rot6d
            if cfg.search.target_on_fk:
                x = robot_state(q, self.vae.fk)
                pos, ori = x[:, 7:10], x[:, 10:16]
        if not cfg.use_collision:
            return q, pos, ori, torch.zeros(len(q), dtype=z.dtype)
        if frames is not None and self.backend.takes_frames:
            return q, pos, ori, self.backend.p_collision(q, z, frames=frames)
        return q, pos, ori, self.backend.p_collision(q, z)

    @torch.no_grad()
    def _errors(self, pos: torch.Tensor, rot6d: torch.Tensor, goal: Goal) -> tuple[np.ndarray, np.ndarray]:
        """Position [m] and orientation [rad] errors (B,) of TCP positions pos (B, 3) and 6D orientations rot6d
        (B, 6) to the goal (no autograd: the losses are computed apart)."""
        target_r = torch.as_tensor(goal.rotation, dtype=pos.dtype)
        pos_err = (pos - torch.as_tensor(goal.position, dtype=pos.dtype)).norm(dim=-1)
        ori_err = rotation_angle_between(rot6d_to_matrix(rot6d), target_r.expand(len(pos), 3, 3))
        return pos_err.numpy().astype(float), ori_err.numpy().astype(float)

    def reached(self, pos_err: float, ori_err: float, goal: Goal) -> bool:
        """Within the goal's tolerances (position only unless use_orientation)."""
        return pos_err < goal.pos_tol and (ori_err < goal.ori_tol or not self.config.use_orientation)

    def iterate(self, s: LatentSearch, goal: Goal, accept: bool, lazy: bool = False) -> dict:
        """One iteration of Algorithm 1 for every seed of `s`; returns what happened (seeds "accepted",
        "reached", "backtraced", "rejected"; per-seed "pos_err" [m], "ori_err" [rad], "p_col").

        lazy: accepted steps are hard-checked only when a seed reaches the goal (SegmentChecker.verify).
        """
        cfg = self.config
        events: dict = {"accepted": [], "reached": [], "backtraced": [], "rejected": []}
        q, pos, ori, p_col = self.decode(s.z)
        pos_err, ori_err = self._errors(pos, ori, goal)
        if accept:
            q_np, p_np = q.detach().double().numpy(), p_col.detach().numpy()
            rejected = cfg.use_collision & (p_np >= cfg.col_threshold)
            events["rejected"] = [int(b) for b in np.flatnonzero(rejected)]
            accept_steps = self._accept_lazily if lazy else self._accept_eagerly
            accept_steps(s, goal, np.flatnonzero(~rejected), q_np, pos_err, ori_err, events)
            if events["reached"]:
                events["pos_err"], events["ori_err"], events["p_col"] = pos_err, ori_err, p_col.detach().numpy()
                return events
            if events["backtraced"]:
                q, pos, ori, p_col = self.decode(s.z)
        target_pos = torch.as_tensor(goal.position, dtype=pos.dtype)
        target_ori = matrix_to_rot6d(torch.as_tensor(goal.rotation, dtype=pos.dtype))
        l_pos = (pos - target_pos).norm(dim=-1)
        l_ori = (ori - target_ori).norm(dim=-1) if cfg.use_orientation else torch.zeros_like(l_pos)
        guided = np.isfinite(s.guide_q[:, 0])
        if guided.any():  # goal guidance: joint-space distance [rad] to the seed's goal configuration
            g = torch.as_tensor(guided)
            l_joint = (q - torch.as_tensor(np.nan_to_num(s.guide_q), dtype=q.dtype)).norm(dim=-1).to(l_pos.dtype)
            l_pos = torch.where(g, l_joint, l_pos)
            l_ori = torch.where(g, torch.zeros_like(l_ori), l_ori)
        l_col = -torch.log1p(-p_col.clamp(max=1 - 1e-6)) if cfg.use_collision else torch.zeros_like(l_pos)
        l_prior = 0.5 * s.z.pow(2).mean(-1)
        lam_t = torch.as_tensor(s.target.update(-l_prior.detach().numpy()), dtype=pos.dtype)
        lam_c = torch.as_tensor(s.col.update(l_col.detach().numpy()), dtype=pos.dtype)
        loss = lam_t * (cfg.lambda_pos * l_pos + cfg.lambda_ori * l_ori) + lam_c * l_col
        if cfg.use_prior:
            loss = loss + l_prior
        s.opt.zero_grad(set_to_none=True)
        loss.sum().backward()
        s.opt.step()
        s.iteration += 1
        s.last_losses = {
            "l_pos": float(l_pos.detach().min()),
            "l_ori": float(l_ori.detach().min()),
            "l_col": float(l_col.detach().min()),
            "l_prior": float(l_prior.detach().min()),
            "lambda_pos": float(cfg.lambda_pos * lam_t.min()),
            "lambda_ori": float(cfg.lambda_ori * lam_t.min()),
            "lambda_col": float(lam_c.max()),
        }
        events["pos_err"], events["ori_err"], events["p_col"] = pos_err, ori_err, p_col.detach().numpy()
        return events

    def _accept_eagerly(self, s: LatentSearch, goal: Goal, candidates, q_np, pos_err, ori_err, events) -> None:
        """Algorithm 1: check the step of every seed in candidates to its decoded state q_np[b] (one batch); accept
        the free ones, back-trace the colliding ones (lambda_target scaled by i/m)."""
        keep_frac = self.config.checks.backtrace_keep
        segs = {int(b): self.segments.densify(s.q_prev[b], q_np[b]) for b in candidates}
        all_hits = self.segments.check_segments(list(segs.values()))
        for b, seg, hits in zip(segs, segs.values(), all_hits, strict=True):
            if hits.any():
                i = int(np.argmax(hits)) + 1
                s.target.scale(np.where(np.arange(len(q_np)) == b, i / len(seg), 1.0))
                keep = int(keep_frac * (i - 1))  # free states of the step kept on the path
                with torch.no_grad():
                    if keep > 0:
                        s.paths[b].append(seg[:keep])
                        s.q_prev[b] = seg[keep - 1]
                        s.z_prev[b] += (keep / len(seg)) * (s.z[b] - s.z_prev[b])
                    s.z[b] = s.z_prev[b]
                s.backtraces += 1
                events["backtraced"].append(b)
                continue
            s.paths[b].append(seg)
            events["accepted"].append(b)
            s.q_prev[b] = q_np[b]
            with torch.no_grad():
                s.z_prev[b] = s.z[b]
            if self.reached(pos_err[b], ori_err[b], goal):
                events["reached"].append(b)

    def _accept_lazily(self, s: LatentSearch, goal: Goal, candidates, q_np, pos_err, ori_err, events) -> None:
        """Accept the decoded states q_np[candidates] unchecked; check the seeds that reach the goal (one batch,
        after the straight segment from the start when it is on) and back-trace those whose steps collide."""
        due = []
        for b in (int(b) for b in candidates):
            s.pending[b].append((q_np[b].copy(), s.z[b].detach().clone()))
            s.q_prev[b] = q_np[b]
            with torch.no_grad():
                s.z_prev[b] = s.z[b]
            if self.reached(pos_err[b], ori_err[b], goal):
                due.append(b)
        unchecked = [b for b in due if self.straight is None or not self.straight.try_end(s, b)]
        hit = set(self.segments.verify(s, unchecked))
        for b in (int(b) for b in candidates):
            if b in hit:
                events["backtraced"].append(b)
                continue
            events["accepted"].append(b)
            if self.reached(pos_err[b], ori_err[b], goal):
                events["reached"].append(b)

    def _restart_stalled(self, s: LatentSearch, b: int, t: int, goal: Goal) -> None:
        """Restart stalled seed b at iteration t from the best seed, targeting a goal configuration when goal
        guidance is on."""
        guide = None if self.guidance is None else self.guidance.target_for_restart(s, goal)
        s.restart(b, t, self.config.search.seed_noise * self.config.search.restart_scale, self.generator, guide)

    # -- open loop ------------------------------------------------------------------------------------
    def plan(
        self,
        start_q: np.ndarray,
        goal: Goal,
        cloud: np.ndarray | None = None,
        origin: np.ndarray | None = None,
        eyes: np.ndarray | None = None,
    ) -> PlanResult:
        """Plan from start_q (7,) [rad] to `goal`; `cloud` (N, 3) [m] is the observed scene, seen from the camera
        origin ((3,), or (N, 3) per point) [m] if known (a scene embedding for the learned backend). `eyes` (K, 3)
        [m]: the cameras' optical centres when no origin is given (the RRT escape's seen-space search; a fused
        cloud whose per-point origins are gone). With plan.geometric_retry, a failure with the network is planned
        again with the geometric backend in the time left (info["geometric_retry"])."""
        cfg, backend = self.config, self.backend
        self._eyes = eyes
        result = self._plan_once(start_q, goal, cloud, origin, cfg.plan.timeout_s)
        left = cfg.plan.timeout_s - result.planning_time_s if cfg.plan.timeout_s > 0 else np.inf
        if result.success or not cfg.plan.geometric_retry or backend.mode != "learned" or left < 0.1:
            return result
        t0 = time.perf_counter()
        with backend.geometric_only():
            retry = self._plan_once(start_q, goal, cloud, origin, 0.0 if not np.isfinite(left) else left)
        spent = result.planning_time_s + (time.perf_counter() - t0)
        retry.info["geometric_retry"] = f"after the network's {result.reason}"
        return replace(retry, planning_time_s=spent, timings={**retry.timings, "total_s": spent})

    def _plan_once(
        self,
        start_q: np.ndarray,
        goal: Goal,
        cloud: np.ndarray | None,
        origin: np.ndarray | None,
        timeout_s: float,
    ) -> PlanResult:
        """One plan with the backend as it is (see `plan`) within timeout_s [s] (0: the step budget alone).

        The result's info["start_refused"] says whether the start itself failed the hard check (see escape_rad).
        """
        cfg = self.config
        t0 = time.perf_counter()
        self.clock.reset()
        start_q = np.asarray(start_q, dtype=float)
        if start_q.shape != (7,) or not np.all(np.isfinite(start_q)):
            raise ValueError(f"start_q must be 7 finite joint positions, got {start_q!r}")
        if cfg.use_collision:
            with self.clock.section("scene"):
                self.backend.set_scene(np.zeros((0, 3)) if cloud is None else cloud, origin)
        if self.escape is not None:
            raw = cloud if isinstance(cloud, np.ndarray) and cfg.use_collision else None  # not an embedding
            self.escape.set_scene(raw, origin if origin is not None else self._eyes)
        with self.segments.cached():  # one scene for the whole plan: each state's answer is kept
            # a start refused by the (conservative) hard check: let the arm move out of it (checks.escape_rad)
            self.segments.escape_from = None
            start_refused = not self.segments.state_free(start_q)
            if start_refused and cfg.checks.escape_rad > 0:
                self.segments.escape_from = start_q
            try:
                return self._search_and_finish(start_q, goal, t0, timeout_s, start_refused)
            finally:
                self.segments.escape_from = None

    def _search_and_finish(
        self, start_q: np.ndarray, goal: Goal, t0: float, timeout_s: float, start_refused: bool
    ) -> PlanResult:
        cfg = self.config
        s = self.new_search(start_q, lr=cfg.search.plan_lr)
        t_setup = time.perf_counter() - t0
        winner = self.finisher.direct_first(s, goal) if self.finisher is not None else None
        straight = winner is not None
        reason = "step budget exhausted" if winner is None else "reached"
        escape_at = t0 + self.escape.config.after_s if self.escape is not None else np.inf  # [s] perf_counter
        escaped = ""  # what the RRT escape reported last, once it ran
        attempts = 0  # escapes run
        for t in range(cfg.max_steps if winner is None else 0):
            with self.clock.section("steps"):
                ev = self.iterate(s, goal, accept=t > 0, lazy=cfg.checks.lazy)
            if ev["reached"]:
                winner, reason = ev["reached"][0], "reached"
                break
            if self.finisher is not None and t > 0 and (b := self.finisher.finish(s, goal, ev)) is not None:
                winner, reason = b, "reached"
                break
            err = ev["pos_err"]
            improved = err < s.best_err - 0.002
            s.best_err = np.where(improved, err, s.best_err)
            with np.errstate(invalid="ignore"):  # guided seeds progress in joint space (NaN: unguided)
                guide_err = np.abs(s.q_prev - s.guide_q).max(axis=1)
                improved |= guide_err < s.best_guide_err - 0.01
            s.best_guide_err = np.fmin(s.best_guide_err, guide_err)
            s.last_improved = np.where(improved, t, s.last_improved)
            stalled = t - s.last_improved > cfg.search.patience
            if stalled.any() and s.restarts < cfg.search.restarts:
                for b in np.flatnonzero(stalled)[: cfg.search.restarts - s.restarts]:
                    self._restart_stalled(s, int(b), t, goal)
            elif np.all(stalled):
                reason = "no progress"
                break
            if timeout_s > 0 and time.perf_counter() - t0 > timeout_s:
                reason = f"timeout ({timeout_s:g} s)"
                break
            if self.escape is not None and time.perf_counter() > escape_at:  # if it fails, the search goes on
                attempts += 1
                winner, escaped = self.escape.run(s, goal)
                if winner is not None:
                    reason = "reached"
                    break
                more = attempts < self.escape.config.attempts
                escape_at = time.perf_counter() + self.escape.config.after_s if more else np.inf
        timed_out = reason.startswith("timeout")
        while winner is None and self.escape is not None and not timed_out and attempts < self.escape.config.attempts:
            if timeout_s > 0 and time.perf_counter() - t0 > timeout_s:  # the plan's time is spent
                break
            attempts += 1
            winner, escaped = self.escape.run(s, goal)
            reason = "reached" if winner is not None else reason
        if winner is None and escaped:
            reason = f"{reason}; {escaped}"
        if winner is None and timed_out:  # out of time: no lazy verification of every seed's steps
            s.paths = [[start_q[None]] for _ in s.paths]  # the start alone, a path known to pass the check
            winner = 0
        elif winner is None:
            self.segments.verify_all(s)
            ends = np.array([self._fk_err(p[-1][-1], goal)[0] for p in s.paths])
            winner = int(np.argmin(ends))
        q_path = np.concatenate(s.paths[winner])
        escape = self.escape
        seen_path = escape is not None and escaped == "escape: rrt" and escape.seen_only  # found in seen space
        if cfg.plan.shortcut and reason == "reached":
            arm = escape.hidden_arm() if escape is not None and seen_path else None
            with self.segments.seen_only(arm) if arm is not None else nullcontext():
                q_path = self._shortcut(s.paths[winner])
        if reason == "reached" and escaped and self.segments.check_segments([q_path])[0].any():
            reason = "escape: rrt path failed the final hard check"  # by construction never; kept as a guard
        result = self._result(s, q_path, winner, goal, reason, time.perf_counter() - t0, t_setup, escaped)
        result.info["start_refused"] = start_refused
        result.info["escape_attempts"] = attempts
        result.info["escape_seen_only"] = bool(seen_path)
        if seen_path and escape is not None:
            result.info["escape_seen_depth_m"] = escape.seen_depth
        if escaped and escape is not None and escape.seen_note:
            result.info["escape_seen_note"] = escape.seen_note  # why no path was found in seen space
        result.info["collision_backend"] = self.backend.mode
        result.info["goal_configurations"] = -1 if s.goal_qs is None else len(s.goal_qs)  # -1: not searched
        result.info["guided"] = bool(np.isfinite(s.guide_q[winner, 0]))
        result.info["direct_first"] = straight  # solved by the straight segment before any optimisation step
        return result

    def _shortcut(self, path: list[np.ndarray]) -> np.ndarray:
        """The checked chain `path` (segments, each ending at an accepted state) shortened by `shortcut`, densified
        at the check resolution: (T, 7) [rad]."""
        vertices = np.stack([seg[-1] for seg in path])
        kept = shortcut(
            vertices,
            self.segments.densify,
            lambda segs: [np.array([not self.segments.free(seg)]) for seg in segs],
        )
        segs = [vertices[:1]] + [
            self.segments.densify(vertices[a], vertices[b]) for a, b in zip(kept[:-1], kept[1:], strict=True)
        ]
        return np.concatenate(segs)

    def segment_free(self, q_from: np.ndarray, q_to: np.ndarray, escape_from: np.ndarray | None = None) -> bool:
        """True if the straight segment q_from (7,) -> q_to (7,) [rad] passes the hard check against the backend's
        current scene (the closed loop's check of a command that did not come from `step`). escape_from (7,)
        [rad]: the start of a plan whose start the check refused; states within checks.escape_rad of it are let
        pass, as `plan` let them."""
        relax = escape_from is not None and self.config.checks.escape_rad > 0
        self.segments.escape_from = escape_from if relax else None
        try:
            return self.segments.segment_free(q_from, q_to)
        finally:
            self.segments.escape_from = None

    def arm_at_goal(self, q: np.ndarray, goal: Goal) -> tuple[bool, float, float]:
        """(within tolerance, position error [m], orientation error [rad]) of q's (7,) [rad] TCP pose to goal."""
        pe, oe = self._fk_err(np.asarray(q, dtype=float), goal)
        return self.reached(pe, oe, goal), pe, oe

    def _fk_err(self, q: np.ndarray, goal: Goal) -> tuple[float, float]:
        pos, rot = self.fk64.ee_pose(torch.as_tensor(q, dtype=torch.float64)[None])
        pe = float((pos[0] - torch.as_tensor(goal.position)).norm())
        oe = float(rotation_angle_between(rot[0], torch.as_tensor(goal.rotation)))
        return pe, oe

    def _result(
        self,
        s: LatentSearch,
        q_path: np.ndarray,
        b: int,
        goal: Goal,
        reason: str,
        elapsed: float,
        t_setup: float,
        escaped: str = "",
    ) -> PlanResult:
        """The PlanResult of seed b's path q_path (T, 7) [rad]; escaped: what the RRT escape reported ("" if it
        did not run), its success shown in the reason as "reached (escape: rrt)"."""
        with torch.no_grad():
            pos, rot = self.fk64.ee_pose(torch.as_tensor(q_path))
        pos_err, ori_err = self._fk_err(q_path[-1], goal)
        success = reason == "reached" and self.reached(pos_err, ori_err, goal)
        timings = self.clock.totals()
        timings["other_s"] = max(0.0, elapsed - sum(timings.values()))  # set-up, bookkeeping, shortcutting
        if success and escaped == "escape: rrt":  # the escape's path (not a latent success after a failed escape)
            reason = f"reached ({escaped})"
        return PlanResult(
            success=success,
            q_path=q_path,
            times=time_parameterise(q_path, self.config.speed_scale),
            ee_positions=pos.numpy(),
            ee_quaternions=matrix_to_quat(rot.numpy()),
            planning_time_s=elapsed,
            reason=reason if success or reason != "reached" else "reached by the model but not by the exact FK",
            final_pos_err_m=pos_err,
            final_ori_err_rad=ori_err,
            iterations=s.iteration,
            timings={**timings, "setup_s": t_setup, "total_s": elapsed},
            info={
                "backtraces": s.backtraces,
                "restarts": s.restarts,
                "seed": b,
                "checked_states": int(self.clock.counts["checked_states"]),
                "escape": escaped,
                **s.last_losses,
            },
        )

    def warm_up(self) -> None:
        """Run a few optimisation steps once, so the first real plan or tick does not pay torch's lazy set-up."""
        pos, rot = self.fk64.ee_pose(torch.as_tensor(Q_READY, dtype=torch.float64)[None])
        goal = Goal(pos[0].numpy(), rot[0].numpy())
        s = self.new_search(Q_READY.copy())
        for accept in (False, True, True):
            self.iterate(s, goal, accept=accept)

    # -- closed loop --------------------------------------------------------------------------------------
    def reset(self) -> None:
        """Forget the closed-loop state (the next `step` re-encodes the measured state)."""
        self._search = None

    @property
    def closed_loop_search(self) -> LatentSearch | None:
        """The closed loop's latent search (None before the first `step` and after `reset`)."""
        return self._search

    def command_target(self, q_from: np.ndarray, q_last: np.ndarray, q_first: np.ndarray) -> np.ndarray:
        """The state to command from q_from (7,) [rad]: q_last when the straight segment to it passes the hard
        check (no check needed when it is q_first, whose segment was checked), else q_first."""
        if np.array_equal(q_last, q_first):
            return q_last
        seg = interpolate(q_from, q_last, self.segments.n_checks(q_from, q_last))
        return q_first if self.segments.check_segments([seg])[0].any() else q_last

    def step(
        self,
        q_measured: np.ndarray,
        goal: Goal,
        cloud: np.ndarray | None = None,
        dt: float = 0.1,
        max_iterations: int = 1,
        resync_rad: float = 0.3,
        budget_s: float | None = None,
        accepted_steps: int = 1,
    ) -> StepResult:
        """One closed-loop tick: at most `max_iterations` optimisation steps, stopping once `accepted_steps` of
        them were accepted (or the goal is reached), and (budget_s [s]) before a step that would likely end past
        the budget (the last step's time as estimate).

        The returned command lies on a collision-checked segment from q_measured: to the last accepted state when
        the straight segment to it passes the hard check (after several accepted steps it is checked once more,
        as one segment), else to the first accepted state (whose segment was checked). It is scaled so no joint
        exceeds speed_scale * its velocity limit over dt [s].
        """
        cfg = self.config
        self.segments.escape_from = None  # the closed loop never relaxes the hard check
        q_measured = np.asarray(q_measured, dtype=float)
        if cloud is not None and cfg.use_collision:
            self.backend.set_scene(cloud)
        s = self._search
        # re-encode when the arm is not where the last command sent it (a reset, a push, a stale start);
        # the latent state may run ahead of the arm, whose commands are velocity-limited
        if s is None or np.abs(s.q_command - q_measured).max() > resync_rad:
            s = self._search = self.new_search(q_measured, cfg.search.closed_loop_seeds)
        s.q_prev[:] = q_measured  # the robot is where it is: check from here
        ev: dict = {}
        first_accepted: dict[int, np.ndarray] = {}  # seed -> its first state accepted in this tick
        n_accepted = 0
        t_start = time.perf_counter()
        for _ in range(max_iterations):
            t_iter = time.perf_counter()
            ev = self.iterate(s, goal, accept=True)
            for i in ev["accepted"]:
                first_accepted.setdefault(i, s.q_prev[i].copy())
            n_accepted += bool(ev["accepted"])
            if ev["reached"] or n_accepted >= accepted_steps:
                break
            now = time.perf_counter()
            if budget_s is not None and (now - t_start) + (now - t_iter) > budget_s:
                break
        for i in range(len(s.paths)):  # the closed loop needs no history: keep memory bounded over long runs
            s.paths[i] = s.paths[i][-1:]
        candidates = ev.get("reached") or list(first_accepted) or [0]
        b = min(candidates, key=lambda i: float(ev["pos_err"][i]) if "pos_err" in ev else 0.0)  # the closest seed
        accepted = b in first_accepted
        target = self.command_target(q_measured, s.q_prev[b], first_accepted[b]) if accepted else q_measured
        delta = target - q_measured
        limit = cfg.speed_scale * V_MAX * dt
        scale = min(1.0, float(np.min(limit / np.maximum(np.abs(delta), 1e-12))))
        command = np.clip(q_measured + scale * delta, Q_MIN, Q_MAX)
        s.q_command = command
        pos_err, ori_err = self._fk_err(s.q_prev[b], goal)
        arm_pos_err, arm_ori_err = self._fk_err(q_measured, goal)
        reached = self.reached(pos_err, ori_err, goal) and self.reached(arm_pos_err, arm_ori_err, goal)
        if reached:
            reason = "reached"
        elif accepted:
            reason = "tracking"
        elif ev.get("backtraced"):
            reason = "backtraced: interpolated step collides"
        elif ev.get("rejected"):
            reason = "rejected: decoded state likely in collision"
        else:
            reason = "optimising"
        return StepResult(
            command=command,
            accepted=accepted,
            reached=reached,
            pos_err_m=pos_err,
            ori_err_rad=ori_err,
            p_collision=float(ev["p_col"][b]) if "p_col" in ev else 0.0,
            reason=reason,
            losses=dict(s.last_losses),
            arm_pos_err_m=arm_pos_err,
        )

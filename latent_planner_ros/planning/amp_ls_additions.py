"""AMP-LS's open-loop additions beyond the seed, as methods of `PlanAdditions` (a base of `AmpLs`).

Exact finish (`_finish`, `_finish_to`), shortcut first (`_direct`), goal guidance (`_goal_configurations`),
restarts of stalled seeds (`_restart`), the RRT escape (`_escape_by_rrt`) and shortcutting of the final path
(`_shortcut`); amp_ls.py describes each. They use the planner's `config`, `panda`, `generator`, `escape` and its
hard checks (`_free`, `_densify`, `_n_checks`, `_check_segments`, `_verify`).
"""

from __future__ import annotations

import time

import numpy as np
import torch

from latent_planner_ros.planning.amp_ls_search import LatentSearch
from latent_planner_ros.planning.escape import goal_states
from latent_planner_ros.planning.goal import Goal
from latent_planner_ros.planning.ik import IkConfig, goal_configurations, solve_ik
from latent_planner_ros.planning.shortcut import shortcut
from latent_planner_ros.planning.time_parameterisation import interpolate
from latent_planner_ros.robot.limits import Q_READY

DIRECT_SKIP_RAD = 0.02
"""shortcut first: an end within this max-joint distance [rad] of one whose straight segment from the start
collided is not tried again (skipping is safe: the seed's own steps are then checked instead)"""

ESCAPE_GOAL_TIMEOUT_S = 0.3
"""the RRT escape: longest search for goal states [s] (part of rrt_escape_budget_s)"""
ESCAPE_START_SEPARATION_RAD = 0.05
"""the RRT escape: the end of a seed's checked chain becomes a start of the tree when it is farther than this
(max joint difference) [rad] from the start and from the other chains' ends"""


class PlanAdditions:
    """The open-loop additions of `AmpLs.plan` (see the module docstring)."""

    def _finish(self, s: LatentSearch, goal: Goal, ev: dict) -> int | None:
        """Exact finish (beyond the seed): a guided seed accepted this iteration within finish_max_rad of its goal
        configuration tries the straight segment to it; else the accepted seed nearest the goal, once its TCP is
        within finish_radius_m / finish_angle_deg, runs damped-least-squares IK from its accepted state to the
        goal pose and tries the segment to the solution. Returns the seed that reached the goal, or None."""
        cfg = self.config
        due = [b for b in ev["accepted"] if s.iteration - s.finish_tried[b] >= cfg.finish_every]
        for b in due:
            if np.isfinite(s.guide_q[b, 0]) and np.abs(s.guide_q[b] - s.q_prev[b]).max() <= cfg.finish_max_rad:
                s.finish_tried[b] = s.iteration
                if self._finish_to(s, b, s.guide_q[b].copy()):
                    return b
        near = [
            b
            for b in due
            if ev["pos_err"][b] < cfg.finish_radius_m
            and ev["ori_err"][b] < np.radians(cfg.finish_angle_deg)
            and s.finish_tried[b] != s.iteration
        ]
        if not near:
            return None
        b = min(near, key=lambda i: float(ev["pos_err"][i]))
        s.finish_tried[b] = s.iteration
        ik = self._finish_ik()
        with self.clock.section("ik"):
            sol = solve_ik(self.panda, goal, s.q_prev[b], ik)
        if not sol.converged or np.abs(sol.q - s.q_prev[b]).max() > cfg.finish_max_rad:
            return None
        return b if self._finish_to(s, b, sol.q) else None

    def _finish_ik(self) -> IkConfig:
        """The IK settings of one exact-finish attempt."""
        cfg = self.config
        return IkConfig(
            max_iters=cfg.finish_ik_iters, max_step_rad=cfg.finish_ik_step_rad, stall_iters=cfg.finish_ik_stall
        )

    def _direct_first(self, s: LatentSearch, goal: Goal) -> int | None:
        """Straight first (`direct_first`): the exact finish's IK from the start, and the straight segment from the
        start to its solution, hard-checked like a step; 0 (the seed whose path it becomes) if it is free."""
        cfg = self.config
        if cfg.finish_radius_m <= 0 or not cfg.shortcut:
            return None
        start = s.paths[0][0][0]
        with self.clock.section("ik"):
            ik = self._finish_ik()
            sol = solve_ik(self.panda, goal, start, ik)
        if not sol.converged or np.abs(sol.q - start).max() > cfg.finish_max_rad:
            return None
        return 0 if self._direct(s, 0, sol.q) else None

    def _direct(self, s: LatentSearch, b: int, q_goal: np.ndarray | None = None) -> bool:
        """Shortcut first (open loop, with `shortcut` on): the straight segment from the start to seed b's last
        accepted state (or to q_goal (7,) [rad]), hard-checked like a step. If it is free it becomes the seed's
        whole path and its unchecked steps are dropped, as shortcutting would drop them; True if it did."""
        if not self.config.shortcut:
            return False
        start = s.paths[b][0][0]
        end = s.q_prev[b] if q_goal is None else q_goal
        if any(np.abs(end - e).max() < DIRECT_SKIP_RAD for e in s.direct_refused):
            return False  # the same end as a refused one (finishes from nearby states find the same IK solution)
        seg = interpolate(start, end, self._n_checks(start, end))
        if not self._free(seg):
            s.direct_refused.append(np.array(end, dtype=float))
            return False
        s.paths[b] = [start[None], seg]
        s.pending[b] = []
        s.q_prev[b] = end
        return True

    def _finish_to(self, s: LatentSearch, b: int, q_goal: np.ndarray) -> bool:
        """Try the straight segment from seed b's accepted state to q_goal (7,) [rad], hard-checked like an
        accepted step (and, checking lazily, the seed's unchecked steps with it); True if it joined the path."""
        if self.config.lazy_check and self._direct(s, b, q_goal):
            return True
        seg = interpolate(s.q_prev[b], q_goal, self._n_checks(s.q_prev[b], q_goal))
        if not self._free(seg):
            return False
        if self.config.lazy_check:
            s.pending[b].append((q_goal, s.z_prev[b].detach().clone()))
            if self._verify(s, [b]):
                return False
        else:
            s.paths[b].append(seg)
        s.q_prev[b] = q_goal
        return True

    def _escape_by_rrt(self, s: LatentSearch, goal: Goal) -> tuple[int | None, str]:
        """The RRT escape (rrt_escape_budget_s): goal states within the goal's tolerance that pass the hard check
        (escape.goal_states, seeded by goal guidance's solutions, the best seed's state, the start and the ready
        pose), then RRTConnect on the hard check, within the budget, to them from the start and from the ends of
        the seeds' checked chains (after a start the hard check refused, the seeds' unchecked steps are checked
        first: their chains lead out of the obstacle the start touches). On success the chain the tree grew from,
        followed by the tree's path, becomes seed 0's path (segments densified as accepted steps) and
        (0, "escape: rrt") is returned; else (None, "escape: rrt, <why not>")."""
        cfg = self.config
        t0 = time.perf_counter()
        start = s.paths[0][0][0]
        seeds = [*(s.goal_qs or []), s.q_prev[int(np.argmin(s.best_err))], start, Q_READY]
        rng = np.random.default_rng(int(torch.randint(0, 2**31 - 1, (1,), generator=self.generator)))
        free = lambda q: not self._check_segments([q])[0].any()  # noqa: E731
        with self.clock.section("ik"):  # the hard checks of its solutions count as checks
            goal_qs = goal_states(self.panda, goal, seeds, free, rng, timeout_s=ESCAPE_GOAL_TIMEOUT_S)
        if not goal_qs:
            return None, "escape: rrt, no goal state passes the hard check"
        if self._escape_from is not None:
            self._verify(s, [b for b in range(len(s.paths)) if s.pending[b]])
        chains = [[start[None]]]  # checked chains from the start, each a list of segments
        for b in range(len(s.paths)):
            if all(np.abs(s.q_ok[b] - c[-1][-1]).max() > ESCAPE_START_SEPARATION_RAD for c in chains):
                chains.append(list(s.paths[b]))
        budget = cfg.rrt_escape_budget_s - (time.perf_counter() - t0)
        with self.clock.section("escape"):
            out = self.escape.solve([c[-1][-1] for c in chains], goal_qs, budget)
        if out.vertices is None:
            return None, f"escape: rrt, {out.reason}"
        v = out.vertices
        s.paths[0] = chains[out.start] + [self._densify(a, c) for a, c in zip(v[:-1], v[1:], strict=True)]
        s.pending[0] = []
        s.q_prev[0] = v[-1]
        return 0, "escape: rrt"

    def _goal_configurations(self, s: LatentSearch, goal: Goal, count: int | None = None) -> list[np.ndarray]:
        """Goal guidance: up to `count` (default goal_guidance) distinct IK solutions (7,) [rad] of the goal that
        pass the hard check, searched once per plan (from the best seed's state, the ready pose, then random
        seeds)."""
        if s.goal_qs is None:
            rng = np.random.default_rng(int(torch.randint(0, 2**31 - 1, (1,), generator=self.generator)))
            with self.clock.section("ik"):  # the hard checks of its solutions count as checks
                search = goal_configurations(
                    self.panda,
                    goal,
                    s.q_prev[int(np.argmin(s.best_err))],
                    lambda q: "hard check" if self._check_segments([q[None]])[0][0] else None,
                    IkConfig(n_seeds=32, max_solutions=count or self.config.goal_guidance, timeout_s=0.5),
                    rng,
                )
            s.goal_qs = search.solutions
        return s.goal_qs

    def _restart(self, s: LatentSearch, b: int, t: int, goal: Goal) -> None:
        """Move stalled seed b to the best seed's last accepted state, with a latent kick (open loop); with goal
        guidance, the seed then targets a goal configuration (the k-th restart the k-th nearest, cyclically)."""
        best = int(np.argmin(s.best_err))
        if self.config.goal_guidance > 0 and (goal_qs := self._goal_configurations(s, goal)):
            order = np.argsort([np.abs(g - s.q_prev[best]).max() for g in goal_qs])
            s.guide_q[b] = goal_qs[order[s.restarts % len(goal_qs)]]
            s.best_guide_err[b] = np.inf
        noise = self.config.seed_noise * self.config.restart_scale
        with torch.no_grad():
            s.z_prev[b] = s.z_prev[best]
            s.z[b] = s.z_prev[best] + noise * torch.randn(s.z.shape[1], generator=self.generator)
        for state in s.opt.state.values():  # forget this seed's optimiser moments
            for v in state.values():
                if torch.is_tensor(v) and v.dim() > 0:
                    v[b] = 0.0
        s.q_prev[b] = s.q_prev[best]
        s.paths[b] = list(s.paths[best])
        s.pending[b] = list(s.pending[best])
        s.q_ok[b] = s.q_ok[best]
        with torch.no_grad():
            s.z_ok[b] = s.z_ok[best]
        for geco in (s.target, s.col):  # the best seed's multipliers
            geco.log_lambda[b] = geco.log_lambda[best]
            if geco.c_ma is not None:
                geco.c_ma[b] = geco.c_ma[best]
        s.best_err[b], s.last_improved[b] = s.best_err[best], t
        s.restarts += 1

    def _shortcut(self, path: list[np.ndarray]) -> np.ndarray:
        """The checked chain `path` (segments, each ending at an accepted state) shortened by `shortcut`, densified
        at the check resolution: (T, 7) [rad]."""
        vertices = np.stack([seg[-1] for seg in path])
        kept = shortcut(
            vertices,
            lambda a, b: interpolate(a, b, self._n_checks(a, b)),
            lambda segs: [np.array([not self._free(seg)]) for seg in segs],
        )
        segs = [vertices[:1]] + [
            interpolate(vertices[a], vertices[b], self._n_checks(vertices[a], vertices[b]))
            for a, b in zip(kept[:-1], kept[1:], strict=True)
        ]
        return np.concatenate(segs)

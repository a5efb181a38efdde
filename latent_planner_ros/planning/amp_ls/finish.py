"""AMP-LS's finishing strategies beyond the seed (open loop): straight first, the exact finish, goal guidance.

The latent optimisation is slow over the last centimetres and stalls at goals that need joints near their
limits. These parts end a plan by straight joint-space segments, each hard-checked like an accepted step:
- `StraightFirst` (with plan.shortcut): a seed that reaches the goal first tries the straight segment from the
  start; if it is free it becomes the seed's whole path.
- `ExactFinish` (config.finish): the seed nearest the goal finishes by damped-least-squares IK from its accepted
  state; `direct_first` tries the same from the start before any optimisation step.
- `GoalGuidance` (config.guidance): IK solutions of the goal that pass the hard check, searched once per plan;
  restarted seeds target one of them in joint space.
"""

from __future__ import annotations

import numpy as np
import torch

from latent_planner_ros.planning.amp_ls.checker import SegmentChecker
from latent_planner_ros.planning.amp_ls.config import FinishConfig, GuidanceConfig
from latent_planner_ros.planning.amp_ls.search import LatentSearch
from latent_planner_ros.planning.goal import Goal
from latent_planner_ros.planning.ik import IkConfig, goal_configurations, solve_ik
from latent_planner_ros.planning.plan_clock import PlanClock
from latent_planner_ros.robot.panda import PandaModel

DIRECT_SKIP_RAD = 0.02
"""straight first: an end within this max-joint distance [rad] of one whose straight segment from the start
collided is not tried again (skipping is safe: the seed's own steps are then checked instead)"""


class StraightFirst:
    """The straight segment from the start to a seed's end, hard-checked like a step (see the module docstring)."""

    def __init__(self, checker: SegmentChecker):
        self.checker = checker

    def try_end(self, s: LatentSearch, b: int, q_goal: np.ndarray | None = None) -> bool:
        """The straight segment from the start to seed b's last accepted state (or to q_goal (7,) [rad]). If it
        is free it becomes the seed's whole path and its unchecked steps are dropped, as shortcutting would drop
        them; True if it did."""
        start = s.start
        end = s.q_prev[b] if q_goal is None else q_goal
        if any(np.abs(end - e).max() < DIRECT_SKIP_RAD for e in s.direct_refused):
            return False  # the same end as a refused one (finishes from nearby states find the same IK solution)
        seg = self.checker.densify(start, end)
        if not self.checker.free(seg):
            s.direct_refused.append(np.array(end, dtype=float))
            return False
        s.paths[b] = [start[None], seg]
        s.pending[b] = []
        s.q_prev[b] = end
        return True


class ExactFinish:
    """Finishing by exact damped-least-squares IK and a checked straight segment (see the module docstring).

    Args:
        config: the finish's settings.
        panda: the robot model the IK runs on.
        checker: the planner's segment checker.
        clock: where the IK's time is counted (section "ik").
        straight: the straight-first part (None: off; `direct_first` then does nothing).
        lazy: the planner checks lazily (a finish then checks the seed's unchecked steps with its segment).
    """

    def __init__(
        self,
        config: FinishConfig,
        panda: PandaModel,
        checker: SegmentChecker,
        clock: PlanClock,
        straight: StraightFirst | None,
        lazy: bool,
    ):
        self.config = config
        self.panda = panda
        self.checker = checker
        self.clock = clock
        self.straight = straight
        self.lazy = lazy
        self.ik = IkConfig(max_iters=config.ik_iters, max_step_rad=config.ik_step_rad, stall_iters=config.ik_stall)

    def finish(self, s: LatentSearch, goal: Goal, ev: dict) -> int | None:
        """A guided seed accepted this iteration within max_rad of its goal configuration tries the straight
        segment to it; else the accepted seed nearest the goal, once within radius_m / angle_deg, runs IK from its
        accepted state to the goal pose and tries the segment to the solution. Returns the seed that reached the
        goal, or None."""
        cfg = self.config
        due = [b for b in ev["accepted"] if s.iteration - s.finish_tried[b] >= cfg.every]
        for b in due:
            if np.isfinite(s.guide_q[b, 0]) and np.abs(s.guide_q[b] - s.q_prev[b]).max() <= cfg.max_rad:
                s.finish_tried[b] = s.iteration
                if self.finish_to(s, b, s.guide_q[b].copy()):
                    return b
        near = [
            b
            for b in due
            if ev["pos_err"][b] < cfg.radius_m
            and ev["ori_err"][b] < np.radians(cfg.angle_deg)
            and s.finish_tried[b] != s.iteration
        ]
        if not near:
            return None
        b = min(near, key=lambda i: float(ev["pos_err"][i]))
        s.finish_tried[b] = s.iteration
        with self.clock.section("ik"):
            sol = solve_ik(self.panda, goal, s.q_prev[b], self.ik)
        if not sol.converged or np.abs(sol.q - s.q_prev[b]).max() > cfg.max_rad:
            return None
        return b if self.finish_to(s, b, sol.q) else None

    def direct_first(self, s: LatentSearch, goal: Goal) -> int | None:
        """Before the first optimisation step: the IK from the start, and the straight segment from the start to
        its solution, hard-checked like a step; 0 (the seed whose path it becomes) if it is free."""
        if not self.config.direct_first or self.straight is None:
            return None
        start = s.start
        with self.clock.section("ik"):
            sol = solve_ik(self.panda, goal, start, self.ik)
        if not sol.converged or np.abs(sol.q - start).max() > self.config.max_rad:
            return None
        return 0 if self.straight.try_end(s, 0, sol.q) else None

    def finish_to(self, s: LatentSearch, b: int, q_goal: np.ndarray) -> bool:
        """Try the straight segment from seed b's accepted state to q_goal (7,) [rad], hard-checked like an
        accepted step (and, checking lazily, the seed's unchecked steps with it); True if it joined the path."""
        if self.lazy and self.straight is not None and self.straight.try_end(s, b, q_goal):
            return True
        seg = self.checker.densify(s.q_prev[b], q_goal)
        if not self.checker.free(seg):
            return False
        if self.lazy:
            s.pending[b].append((q_goal, s.z_prev[b].detach().clone()))
            if self.checker.verify(s, [b]):
                return False
        else:
            s.paths[b].append(seg)
        s.q_prev[b] = q_goal
        return True


class GoalGuidance:
    """Goal configurations for restarted seeds (see the module docstring).

    Args:
        config: the guidance's settings.
        panda: the robot model the IK runs on.
        checker: the planner's segment checker (solutions must pass its hard check).
        clock: where the search's time is counted (section "ik").
        generator: the planner's torch generator (seeds the search's sampling).
    """

    def __init__(
        self,
        config: GuidanceConfig,
        panda: PandaModel,
        checker: SegmentChecker,
        clock: PlanClock,
        generator: torch.Generator,
    ):
        self.config = config
        self.panda = panda
        self.checker = checker
        self.clock = clock
        self.generator = generator

    def configurations(self, s: LatentSearch, goal: Goal, count: int | None = None) -> list[np.ndarray]:
        """Up to `count` (default config.solutions) distinct IK solutions (7,) [rad] of the goal that pass the
        hard check, searched once per plan (from the best seed's state, the ready pose, then random seeds)."""
        if s.goal_qs is None:
            rng = np.random.default_rng(int(torch.randint(0, 2**31 - 1, (1,), generator=self.generator)))
            with self.clock.section("ik"):  # the hard checks of its solutions count as checks
                search = goal_configurations(
                    self.panda,
                    goal,
                    s.q_prev[s.best()],
                    lambda q: None if self.checker.state_free(q) else "hard check",
                    IkConfig(n_seeds=32, max_solutions=count or self.config.solutions, timeout_s=0.5),
                    rng,
                )
            s.goal_qs = search.solutions
        return s.goal_qs

    def target_for_restart(self, s: LatentSearch, goal: Goal) -> np.ndarray | None:
        """The goal configuration (7,) [rad] the next restarted seed targets (the k-th restart the k-th nearest to
        the best seed's state, cyclically), or None when no goal configuration passes the hard check."""
        goal_qs = self.configurations(s, goal)
        if not goal_qs:
            return None
        best = s.best()
        order = np.argsort([np.abs(g - s.q_prev[best]).max() for g in goal_qs])
        return goal_qs[order[s.restarts % len(goal_qs)]]

"""AMP-LS's RRT escape (config.escape, open loop): the sampled way out of the local minima of the latent search.

Once escape.after_s of wall time passed without the goal (or earlier, when the latent search ends: every seed
stalled or the step budget spent), RRTConnect searches joint space from the start to goal configurations on the
planner's own hard check, within escape.budget_s (planning/escape.py); its path is shortcut like any other, and
the result says so (reason "reached (escape: rrt)", info["escape"]).
"""

from __future__ import annotations

import time

import numpy as np
import torch

from latent_planner_ros.planning.amp_ls.checker import SegmentChecker
from latent_planner_ros.planning.amp_ls.config import EscapeConfig
from latent_planner_ros.planning.amp_ls.search import LatentSearch
from latent_planner_ros.planning.escape import RrtEscape, goal_states
from latent_planner_ros.planning.goal import Goal
from latent_planner_ros.planning.plan_clock import PlanClock
from latent_planner_ros.robot.limits import Q_READY
from latent_planner_ros.robot.panda import PandaModel

ESCAPE_GOAL_TIMEOUT_S = 0.3
"""longest search for goal states [s] (part of escape.budget_s)"""
ESCAPE_START_SEPARATION_RAD = 0.05
"""the end of a seed's checked chain becomes a start of the tree when it is farther than this (max joint
difference) [rad] from the start and from the other chains' ends"""


class RrtEscapePart:
    """The RRT escape of a planner (see the module docstring).

    Args:
        config: the escape's budget and trigger.
        panda: the robot model (goal IK).
        checker: the planner's segment checker (every state and motion of the tree passes it).
        clock: where the time goes (sections "ik" and "escape").
        generator: the planner's torch generator (seeds the sampling).
    """

    def __init__(
        self,
        config: EscapeConfig,
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
        self.rrt = RrtEscape(checker.free, checker.densify)

    def run(self, s: LatentSearch, goal: Goal) -> tuple[int | None, str]:
        """Goal states within the goal's tolerance that pass the hard check (escape.goal_states, seeded by goal
        guidance's solutions, the best seed's state, the start and the ready pose), then RRTConnect on the hard
        check, within the budget, to them from the start and from the ends of the seeds' checked chains (after a
        start the hard check refused, the seeds' unchecked steps are checked first: their chains lead out of the
        obstacle the start touches). On success the chain the tree grew from, followed by the tree's path, becomes
        seed 0's path (segments densified as accepted steps) and (0, "escape: rrt") is returned; else
        (None, "escape: rrt, <why not>")."""
        t0 = time.perf_counter()
        start = s.start
        seeds = [*(s.goal_qs or []), s.q_prev[s.best()], start, Q_READY]
        rng = np.random.default_rng(int(torch.randint(0, 2**31 - 1, (1,), generator=self.generator)))
        with self.clock.section("ik"):  # the hard checks of its solutions count as checks
            free = lambda qs: not self.checker.check_segments([qs])[0].any()  # noqa: E731  qs (1, 7) [rad]
            goal_qs = goal_states(self.panda, goal, seeds, free, rng, timeout_s=ESCAPE_GOAL_TIMEOUT_S)
        if not goal_qs:
            return None, "escape: rrt, no goal state passes the hard check"
        if self.checker.escape_from is not None:
            self.checker.verify_all(s)
        chains = [[start[None]]]  # checked chains from the start, each a list of segments
        for b in range(len(s.paths)):
            if all(np.abs(s.q_ok[b] - c[-1][-1]).max() > ESCAPE_START_SEPARATION_RAD for c in chains):
                chains.append(list(s.paths[b]))
        budget = self.config.budget_s - (time.perf_counter() - t0)
        with self.clock.section("escape"):
            out = self.rrt.solve([c[-1][-1] for c in chains], goal_qs, budget)
        if out.vertices is None:
            return None, f"escape: rrt, {out.reason}"
        v = out.vertices
        s.paths[0] = chains[out.start] + [self.checker.densify(a, c) for a, c in zip(v[:-1], v[1:], strict=True)]
        s.pending[0] = []
        s.q_prev[0] = v[-1]
        return 0, "escape: rrt"

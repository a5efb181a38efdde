"""AMP-LS's RRT escape (config.escape, open loop): the sampled way out of the local minima of the latent search.

Once escape.after_s of wall time passed without the goal (or earlier, when the latent search ends: every seed
stalled or the step budget spent), RRTConnect searches joint space from the start to goal configurations on the
planner's own hard check, within escape.budget_s (planning/escape.py); its path is shortcut like any other, and
the result says so (reason "reached (escape: rrt)", info["escape"]).

Every unsafe plan measured on the workcell sets was an escape path through geometry no camera saw (the back of a
pillar, the far side of a wall). So the escape first searches, for escape.seen_share of its budget, on a stricter
check that also refuses any state putting part of the arm where every camera's view is blocked by an observed
surface (planning/shadow_map.py); only if that finds no path does it search on the hard check alone, with its
whole budget again (so an escape takes at most (1 + seen_share) x budget_s). A path found
in seen space is shortcut on the same strict check (`seen_only`), so the shortcut does not pull it back behind
the surfaces. escape.fallback_depths_m (off by default: measured no safer, docs/benchmark.md) adds seen-space
searches that let the arm lie that far behind a surface; `seen_note` says why the seen-space searches failed.
"""

from __future__ import annotations

import time

import numpy as np
import torch

from latent_planner_ros.perception.cloud_fusion import camera_eyes
from latent_planner_ros.planning.amp_ls.checker import SegmentChecker
from latent_planner_ros.planning.amp_ls.config import EscapeConfig
from latent_planner_ros.planning.amp_ls.search import LatentSearch
from latent_planner_ros.planning.escape import EscapeResult, RrtEscape, goal_states
from latent_planner_ros.planning.goal import Goal
from latent_planner_ros.planning.plan_clock import PlanClock
from latent_planner_ros.planning.shadow_map import HiddenArm, ShadowMap
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
        self._scene: tuple[np.ndarray, np.ndarray] | None = None  # cloud, origin(s) or camera centres of the plan
        self._arm: HiddenArm | None = None  # the sphere model, built once; its shadow per scene
        self._shadow_of: tuple[np.ndarray, np.ndarray] | None = None  # the scene the arm's shadow was built for
        self.seen_only = False
        """whether the last escape's path was found on the seen-space check (its shortcut must use it too)"""
        self.seen_note = ""
        """why the last escape's seen-space searches found no path ("" when one did or none ran)"""
        self.seen_depth = 0.0
        """[m] the depth behind observed surfaces (ShadowMap.depth_m) of the seen-space search that found the path"""

    def set_scene(self, cloud: np.ndarray | None, origin: np.ndarray | None) -> None:
        """The plan's cloud (N, 3) [m] and where it was seen from: per-point origins (N, 3), or the cameras'
        centres ((3,) or (K, 3)) [m]; None: unknown, no seen-space search."""
        self._scene = None if cloud is None or origin is None or not len(cloud) else (cloud, origin)
        self.seen_only, self.seen_note = False, ""

    def hidden_arm(self) -> HiddenArm | None:
        """The HiddenArm of the current scene (its ShadowMap built on first use, 15-30 ms for 40k points and 3
        cameras here), or None without camera origins (its shadow None when none of them is finite)."""
        if self._scene is None:
            return None
        if self._arm is None:
            self._arm = HiddenArm()
        if self._shadow_of is not self._scene:
            cloud, origin = self._scene
            eyes = camera_eyes(origin)
            self._arm.shadow = None if eyes is None else ShadowMap(cloud, eyes, depth_m=self.config.seen_depth_m)
            self._shadow_of = self._scene
        return self._arm

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
        starts = [c[-1][-1] for c in chains]
        t_ik = time.perf_counter()
        out = self._seen_first(starts, goal_qs) if self.config.seen_share > 0 else None
        self.seen_only = out is not None
        if out is None:  # the whole budget again (goal IK excepted): the seen search must not cost a success
            budget = self.config.budget_s - (t_ik - t0)
            with self.clock.section("escape"):
                out = self.rrt.solve(starts, goal_qs, budget)
        if out.vertices is None:
            return None, f"escape: rrt, {out.reason}"
        v = out.vertices
        s.paths[0] = chains[out.start] + [self.checker.densify(a, c) for a, c in zip(v[:-1], v[1:], strict=True)]
        s.pending[0] = []
        s.q_prev[0] = v[-1]
        return 0, "escape: rrt"

    def _seen_first(self, starts: list[np.ndarray], goal_qs: list[np.ndarray]) -> EscapeResult | None:
        """RRTConnect on the seen-space check (`SegmentChecker.seen_only`) from the starts and to the goal states
        (each (7,) [rad]) that pass it, within escape.seen_share x escape.budget_s, at seen_depth_m and then at
        each of escape.fallback_depths_m; the found result (its start index into `starts`), or None (no camera
        origins, or at every depth no start or goal state in seen space or no path; `seen_note` says which)."""
        self.seen_note = ""
        with self.clock.section("escape"):  # the shadow map's time counts as the escape's
            arm = self.hidden_arm()
        if arm is None or arm.shadow is None:
            return None
        notes = []
        for depth in (self.config.seen_depth_m, *self.config.fallback_depths_m):
            arm.shadow.depth_m = depth  # kept on success: the path's shortcut uses the same check
            with self.clock.section("escape"), self.checker.seen_only(arm):
                ok_starts = [i for i, q in enumerate(starts) if self.checker.state_free(q)]
                ok_goals = [q for q in goal_qs if self.checker.state_free(q)]
                if not ok_starts or not ok_goals:
                    notes.append(f"{depth * 100:g} cm: no {'start' if not ok_starts else 'goal state'} in seen space")
                    continue
                budget = self.config.seen_share * self.config.budget_s
                out = self.rrt.solve([starts[i] for i in ok_starts], ok_goals, budget)
            if out.vertices is not None:
                self.seen_depth = depth
                return EscapeResult(out.vertices, out.reason, out.elapsed_s, out.motions, ok_starts[out.start])
            notes.append(f"{depth * 100:g} cm: {out.reason}")
        self.seen_note = "; ".join(notes)
        return None

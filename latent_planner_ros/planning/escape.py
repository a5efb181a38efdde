"""A sampled escape for AMP-LS: OMPL's RRTConnect in joint space, on AMP-LS's own hard check.

The latent optimisation is local: in a bin, under a shelf or behind a thin wall every seed can stall at a
local minimum that a global sampler gets out of. `RrtEscape.solve` grows RRTConnect trees from the start and
from goal configurations (IK solutions that passed the hard check). Every state OMPL asks about and every
motion it wants to take goes through the planner's hard check: a motion is densified exactly as an accepted
step of AMP-LS (`densify`), so each segment of the returned chain has passed the same check as every other
AMP-LS path.

    escape = RrtEscape(free, densify)
    out = escape.solve([start_q], goal_qs, budget_s=1.0)   # out.vertices: (K, 7) [rad] or None

OMPL calls the Python callbacks from its planning thread; RRTConnect runs no helper thread, so this is safe.
Not thread-safe: use one instance per planner.
"""

from __future__ import annotations

import math
import time
import weakref
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
import pinocchio as pin
from ompl import base as ob
from ompl import geometric as og

from latent_planner_ros.planning.goal import Goal
from latent_planner_ros.planning.ik import IkConfig, is_position_only, solve_ik
from latent_planner_ros.planning.ompl_baseline import joint_space
from latent_planner_ros.robot.limits import Q_MAX, Q_MIN
from latent_planner_ros.robot.panda import PandaModel

SEPARATION_RAD = 0.1
"""goal states closer than this (max joint difference) [rad] to a kept one are duplicates"""
RANGE_RAD = 1.0
"""largest extension of one RRTConnect step [rad] (Euclidean in joint space; OMPL's default, a fifth of the
joint box's diagonal, is about 2.5 rad, whose motions need over 100 checked states each)"""


GOAL_SLACK = 0.7
"""goal states may sit this fraction of the goal's position and orientation tolerances away from the exact pose"""


def goal_states(
    panda: PandaModel,
    goal: Goal,
    seeds: Sequence[np.ndarray],
    free: Callable[[np.ndarray], bool],
    rng: np.random.Generator,
    max_states: int = 4,
    repairs: int = 8,
    timeout_s: float = 0.3,
) -> list[np.ndarray]:
    """Up to max_states distinct configurations (7,) [rad] that pass the hard check `free` and reach `goal`
    within GOAL_SLACK of its tolerances.

    Damped-least-squares IK runs from `seeds` (each (7,) [rad]), then from uniform samples within the joint
    limits. The hard check is conservative, so an exact IK solution next to an obstacle is often refused while
    configurations a few millimetres or degrees off the pose pass (the latent optimisation ends at those): a
    refused solution is repaired by up to `repairs` IK runs from it towards poses drawn within the slack.
    Stops after timeout_s [s].
    """
    t0 = time.perf_counter()
    found: list[np.ndarray] = []
    exact = IkConfig(max_iters=150, stall_iters=12)
    nearby = IkConfig(max_iters=30, stall_iters=8)
    pos_slack = GOAL_SLACK * goal.pos_tol
    ori_slack = 0.0 if is_position_only(goal) else GOAL_SLACK * goal.ori_tol
    k = 0
    while len(found) < max_states and time.perf_counter() - t0 < timeout_s:
        seed = seeds[k] if k < len(seeds) else rng.uniform(Q_MIN, Q_MAX)
        k += 1
        sol = solve_ik(panda, goal, seed, exact)
        if not sol.converged or any(np.abs(sol.q - f).max() < SEPARATION_RAD for f in found):
            continue
        q = sol.q if free(sol.q[None]) else None
        for _ in range(repairs if q is None else 0):
            d = rng.normal(size=3)
            d *= pos_slack * rng.uniform() ** (1 / 3) / np.linalg.norm(d)
            w = rng.normal(size=3)
            w *= ori_slack * rng.uniform() / np.linalg.norm(w)
            near = Goal(goal.position + d, pin.exp3(w) @ goal.rotation, goal.pos_tol, goal.ori_tol)
            fix = solve_ik(panda, near, sol.q, nearby)
            if fix.converged and free(fix.q[None]):
                q = fix.q
                break
        if q is not None:
            found.append(q)
    return found


@dataclass(frozen=True)
class EscapeResult:
    """The outcome of one escape.

    Attributes:
        vertices: (K, 7) [rad] the chain from a start to one of the goal configurations (consecutive vertices
            joined by segments that passed the hard check), or None when none was found.
        reason: "found", or why not.
        elapsed_s: wall-clock time of the search [s].
        motions: motions checked (segments between two states).
        start: index of the start the chain begins at.
    """

    vertices: np.ndarray | None
    reason: str
    elapsed_s: float
    motions: int
    start: int = 0


class _MotionValidator(ob.MotionValidator):
    """OMPL motion validation by the planner's hard check of the densified segment (one batch per motion)."""

    def __init__(self, si, escape: RrtEscape):
        super().__init__(si)
        self._escape = weakref.ref(escape)  # weakly: OMPL's side would make a cycle Python cannot free

    def checkMotion(self, s1, s2, *last_valid) -> bool:  # noqa: N802 (OMPL's name)
        escape = self._escape()
        return False if escape is None else escape._motion_free(s1, s2)


class RrtEscape:
    """RRTConnect between a start and goal configurations, every state and motion on a given hard check.

    Args:
        free: segment (m, 7) [rad] -> True if every state passes the hard check.
        densify: (q_from (7,), q_to (7,)) -> the states (m, 7) [rad] to check on the straight segment, q_from
            excluded, q_to included (AMP-LS's interpolation of an accepted step).
        range_rad: largest extension of one tree step [rad] (Euclidean in joint space).
    """

    def __init__(
        self,
        free: Callable[[np.ndarray], bool],
        densify: Callable[[np.ndarray, np.ndarray], np.ndarray],
        range_rad: float = RANGE_RAD,
    ):
        self.free = free
        self.densify = densify
        self.range_rad = float(range_rad)
        self._space, self._si = joint_space(self._state_valid)
        self._validator = _MotionValidator(self._si, self)  # kept alive here: OMPL holds only a pointer
        self._si.setMotionValidator(self._validator)
        self._si.setup()
        self._error = ""
        self._motions = 0

    # -- OMPL glue --------------------------------------------------------------------------------------
    @staticmethod
    def _q(state) -> np.ndarray:
        return np.fromiter((state[i] for i in range(7)), dtype=float, count=7)

    def _state(self, q: np.ndarray):
        s = self._space.allocState()
        for i in range(7):
            s[i] = float(q[i])
        return s

    def _state_valid(self, state) -> bool:
        try:
            return bool(self.free(self._q(state)[None]))
        except Exception as err:  # an exception must not cross into OMPL's C++ loop
            self._error = f"{type(err).__name__}: {err}"
            return False

    def _motion_free(self, s1, s2) -> bool:
        try:
            self._motions += 1
            return bool(self.free(self.densify(self._q(s1), self._q(s2))))
        except Exception as err:
            self._error = f"{type(err).__name__}: {err}"
            return False

    # -- search -------------------------------------------------------------------------------------------
    def solve(self, starts: Sequence[np.ndarray], goal_qs: Sequence[np.ndarray], budget_s: float) -> EscapeResult:
        """A chain from one of `starts` to one of goal_qs (each (7,) [rad]) within budget_s [s] of search."""
        t0 = time.perf_counter()
        self._error, self._motions = "", 0
        if not goal_qs:
            return EscapeResult(None, "no goal configuration", 0.0, 0)
        if not (math.isfinite(budget_s) and budget_s > 0):
            return EscapeResult(None, "no time left", 0.0, 0)
        pdef = ob.ProblemDefinition(self._si)
        for q in starts:
            pdef.addStartState(self._state(q))
        goals = ob.GoalStates(self._si)
        for q in goal_qs:
            goals.addState(self._state(q))
        pdef.setGoal(goals)
        planner = og.RRTConnect(self._si)
        planner.setRange(self.range_rad)
        planner.setProblemDefinition(pdef)
        planner.setup()
        status = planner.solve(float(budget_s))
        elapsed = time.perf_counter() - t0
        if self._error:
            return EscapeResult(None, f"hard check failed: {self._error}", elapsed, self._motions)
        if not pdef.hasExactSolution():
            return EscapeResult(None, f"no path within {budget_s:.2f} s ({status})", elapsed, self._motions)
        path = pdef.getSolutionPath()
        vertices = np.array([self._q(path.getState(k)) for k in range(path.getStateCount())])
        start = int(np.argmin([np.abs(vertices[0] - q).max() for q in starts]))
        vertices[0] = starts[start]  # exactly (OMPL states hold the same doubles)
        return EscapeResult(vertices, "found", elapsed, self._motions, start)

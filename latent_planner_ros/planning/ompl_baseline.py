"""The OMPL baseline: joint-space sampling-based planning to an end-effector goal pose on an occupancy map.

What MoveIt does with its OMPL plugin and an octomap, in one process (seed chapter 7 section V-B):
  1. the observed cloud becomes a coal.OcTree (OccupancyMap); a configuration is valid when it is within the
     joint limits, free of self and table collision and no link touches an occupied voxel (OctreeChecker);
  2. the goal pose becomes joint-space goal states: distinct valid IK solutions from several DLS seeds;
  3. an OMPL planner searches the 7-D joint box (motions checked every `check_step_deg`): RRTConnect and
     LBKPIECE1 until their first solution or `timeout_s`, RRTstar, PRMstar and BITstar for the fixed
     `anytime_budget_s`, minimising joint-space path length;
  4. the solution is optionally simplified (PathSimplifier), densified and time-parameterised.

    planner = OmplPlanner(OmplConfig(planner="rrtconnect"))
    result = planner.plan(start_q, goal, cloud)   # a PlanResult; failures carry a reason, never raise

OMPL calls the Python validity checker from the planning thread; PRMstar also runs a helper thread that
must not call Python (it would deadlock on the GIL), so PRMstar gets a single goal state.
"""

from __future__ import annotations

import inspect
import math
import time
import weakref
from collections.abc import Callable

import numpy as np
from ompl import base as ob
from ompl import geometric as og
from ompl import util as ou

from latent_planner_ros.planning.goal import Goal
from latent_planner_ros.planning.ik import goal_configurations
from latent_planner_ros.planning.octree_checker import OccupancyMap, OctreeChecker
from latent_planner_ros.planning.ompl_baseline_config import PLANNERS, OmplConfig
from latent_planner_ros.planning.result import PlanResult, result_from_path
from latent_planner_ros.planning.state_validity import StateValidity
from latent_planner_ros.robot.limits import Q_MAX, Q_MIN
from latent_planner_ros.robot.panda import PandaModel, load_panda

START_LIMIT_SLACK = 1e-3
"""A start this little outside the joint limits [rad] (measurement noise) is clamped into them."""

_OMPL_SEED: list[int] = []


def seed_ompl(seed: int) -> bool:
    """Seed OMPL's random numbers for this process; False if it was already seeded with another seed.

    OMPL takes one seed per process, before its first sampler exists: call this before the first plan.
    """
    if _OMPL_SEED:
        return _OMPL_SEED[0] == seed
    ou.RNG.setSeed(int(seed))
    _OMPL_SEED.append(seed)
    return True


def densify(q_path: np.ndarray, step_rad: float) -> np.ndarray:
    """Waypoints (T', 7) on the polyline q_path (T, 7) [rad], no joint moving more than step_rad between two."""
    q_path = np.atleast_2d(q_path)
    out = [q_path[:1]]
    for a, b in zip(q_path[:-1], q_path[1:], strict=True):
        k = max(1, math.ceil(float(np.abs(b - a).max()) / step_rad))
        out.append(a + (b - a) * (np.arange(1, k + 1) / k)[:, None])
    return np.concatenate(out)


def weak_method(method: Callable[..., bool]) -> Callable[..., bool]:
    """`method` (a bound method) called through a weak reference to its object: False once the object is gone.

    OMPL's C++ objects hold the Python callbacks they are given, and Python's garbage collector cannot see
    through C++: an owner whose SpaceInformation holds its own bound method is a cycle that is never freed (each
    planner built and dropped would stay in memory). Callbacks given to OMPL go through this instead.
    """
    ref = weakref.WeakMethod(method)

    def call(*args) -> bool:
        bound = ref()
        return False if bound is None else bound(*args)

    return call


def joint_space(state_valid) -> tuple[ob.RealVectorStateSpace, ob.SpaceInformation]:
    """The Panda's 7-D joint space within its limits and its SpaceInformation, whose states are checked by
    `state_valid(state) -> bool` (a bound method is held weakly, see `weak_method`); OMPL's log quietened to
    warnings."""
    if ou.getLogLevel().value < ou.LOG_WARN.value:
        ou.setLogLevel(ou.LOG_WARN)
    space = ob.RealVectorStateSpace(7)
    bounds = ob.RealVectorBounds(7)
    for i in range(7):
        bounds.setLow(i, float(Q_MIN[i]))
        bounds.setHigh(i, float(Q_MAX[i]))
    space.setBounds(bounds)
    si = ob.SpaceInformation(space)
    si.setStateValidityChecker(weak_method(state_valid) if inspect.ismethod(state_valid) else state_valid)
    return space, si


class OmplPlanner:
    """An OMPL planner behind the shared planner protocol (`name`, `plan(start_q, goal, cloud)`).

    Not thread-safe: use one instance per thread or process.

    Args:
        config: planner choice, budgets, occupancy map, IK and output settings.
        panda: the pinocchio model (default: the shared one).
    """

    def __init__(self, config: OmplConfig | None = None, panda: PandaModel | None = None):
        self.config = config or OmplConfig()
        self.name = self.config.planner
        self.panda = panda or load_panda()
        self._octree = OctreeChecker(table=self.config.table, padding=self.config.padding, panda=self.panda)
        self.checker: StateValidity = self._octree
        """the state validity of every query (the occupancy map's here; subclasses may give another)"""
        self._rng = np.random.default_rng(self.config.seed)
        self._space, self._si = joint_space(self._state_valid)
        step = math.radians(self.config.check_step_deg)
        self._si.setStateValidityCheckingResolution(step / self._space.getMaximumExtent())
        self._si.setup()
        self._callback_error = ""

    # -- OMPL glue -------------------------------------------------------------------------------------
    def _state_valid(self, state) -> bool:
        try:
            return self.checker.is_valid(np.fromiter((state[i] for i in range(7)), dtype=float, count=7))
        except Exception as err:  # an exception must not cross into OMPL's C++ loop
            self._callback_error = f"{type(err).__name__}: {err}"
            return False

    def _state(self, q: np.ndarray):
        s = self._space.allocState()
        for i in range(7):
            s[i] = float(q[i])
        return s

    def _make_planner(self):
        planner = getattr(og, PLANNERS[self.config.planner][0])(self._si)
        if self.config.range_rad > 0 and hasattr(planner, "setRange"):
            planner.setRange(self.config.range_rad)
        return planner

    # -- planning -------------------------------------------------------------------------------------
    def plan(
        self, start_q: np.ndarray, goal: Goal, cloud: np.ndarray | None = None, origin: np.ndarray | None = None
    ) -> PlanResult:
        """Plan from start_q (7,) [rad] to `goal` around the occupied voxels of cloud (N, 3) [m] in `world`
        (the camera origin is not used: the occupancy map marks observed points only).

        Raises:
            ValueError: start_q is not 7 finite numbers (a caller's bug; planning failures return a result).
        """
        cfg = self.config
        t0 = time.perf_counter()
        start_q = np.asarray(start_q, dtype=float)
        if start_q.shape != (7,) or not np.all(np.isfinite(start_q)):
            raise ValueError(f"start_q must be 7 finite joint positions, got {start_q!r}")
        self.checker.checks = 0
        self._callback_error = ""
        timings: dict[str, float] = {}
        info: dict = {"planner": PLANNERS[cfg.planner][0]}

        self._load_obstacles(cloud, timings, info)

        def fail(reason: str) -> PlanResult:
            return self._result(start_q[None], goal, False, reason, t0, timings, info)

        if np.any(start_q < Q_MIN - START_LIMIT_SLACK) or np.any(start_q > Q_MAX + START_LIMIT_SLACK):
            return fail("start state invalid: outside the joint limits")
        start_q = np.clip(start_q, Q_MIN, Q_MAX)
        why = self.checker.invalid_reason(start_q)
        if why is not None:
            return fail(f"start state invalid: {why}")
        why = self._goal_blocked(goal)
        if why is not None:
            return fail(f"goal invalid: {why}")

        t = time.perf_counter()
        ik = goal_configurations(self.panda, goal, start_q, self.checker.invalid_reason, cfg.ik, self._rng)
        timings["ik_s"] = time.perf_counter() - t
        info.update(ik_attempts=ik.attempts, goal_states=len(ik.solutions))
        if not ik.solutions:
            return fail(ik.failure_reason())
        goals = ik.solutions
        if cfg.planner == "prmstar":  # one goal state: PRM's helper thread would sample more through Python
            goals = [min(goals, key=lambda q: float(np.linalg.norm(q - start_q)))]

        t = time.perf_counter()
        pdef = ob.ProblemDefinition(self._si)
        pdef.addStartState(self._state(start_q))
        goal_states = ob.GoalStates(self._si)
        for q in goals:
            goal_states.addState(self._state(q))
        pdef.setGoal(goal_states)
        pdef.setOptimizationObjective(ob.PathLengthOptimizationObjective(self._si))
        planner = self._make_planner()
        planner.setProblemDefinition(pdef)
        planner.setup()
        status = planner.solve(cfg.budget_s)
        timings["solve_s"] = time.perf_counter() - t
        info["status"] = str(status)
        if self._callback_error:
            return fail(f"collision checking failed: {self._callback_error}")
        if not pdef.hasExactSolution():
            budget = f"the {cfg.budget_s:g} s budget" if cfg.anytime else f"{cfg.budget_s:g} s"
            return fail(f"no collision-free path found within {budget} ({status})")

        path = pdef.getSolutionPath()
        info["path_states_raw"] = path.getStateCount()
        if cfg.simplify:
            t = time.perf_counter()
            og.PathSimplifier(self._si, goal_states).simplify(path, cfg.simplify_time_s)
            timings["simplify_s"] = time.perf_counter() - t
        q_path = np.array([[path.getState(k)[i] for i in range(7)] for k in range(path.getStateCount())])
        info["path_states"] = len(q_path)
        q_path = densify(q_path, math.radians(cfg.waypoint_step_deg))
        return self._result(q_path, goal, True, "reached", t0, timings, info)

    def _load_obstacles(self, cloud: np.ndarray | None, timings: dict, info: dict) -> None:
        """Give the checker the obstacles of this query: the occupancy map of cloud (N, 3) [m]."""
        t = time.perf_counter()
        self._occupancy = OccupancyMap.from_cloud(cloud, self.config.octree_resolution, self.config.min_z)
        self._octree.set_occupancy(self._occupancy)
        timings["octree_s"] = time.perf_counter() - t
        info["cloud_points"] = self._occupancy.points_used

    def _goal_blocked(self, goal: Goal) -> str | None:
        """Why the goal position cannot be reached by any configuration, or None."""
        if self._occupancy.contains(goal.position):
            return "the goal position is inside an occupied voxel"
        return None

    def _result(
        self, q_path: np.ndarray, goal: Goal, solved: bool, reason: str, t0: float, timings: dict, info: dict
    ) -> PlanResult:
        return result_from_path(
            self.panda,
            q_path,
            goal,
            solved=solved,
            reason=reason,
            t0=t0,
            speed_scale=self.config.speed_scale,
            iterations=self.checker.checks,
            timings=timings,
            info=info,
        )

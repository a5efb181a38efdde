"""Run one-shot plans beside the control loop: on a worker thread (the node) or deferred in simulated time (benches).

ROS-free. The closed loop submits a PlanRequest and polls for its outcome at every tick; it never waits. Only
the newest request matters: a request submitted while another runs replaces any request still waiting, and the
outcome of a superseded request is still returned (the caller compares `ident`s and drops stale ones).

`plan_fn` is typically `planning_function(planner, lock)`: a planner instance of its own (its own collision
backend, so the closed loop's scene updates never race with a running plan), under a lock it shares with any
other user of that instance (the node's ~/plan service).
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from latent_planner_ros.planning.goal import Goal
from latent_planner_ros.planning.goal_reachability import refused_result, unreachable_reason
from latent_planner_ros.planning.grasp import GraspSpec, plan_grasp_spec
from latent_planner_ros.planning.result import PlanResult


@dataclass(frozen=True)
class PlanRequest:
    """One plan: from q (7,) [rad] to goal, in scene (what the planner's backend consumes: a cloud (N, 3) [m]
    or a scene embedding; None without collision checking) with the raw cloud (N, 3) [m] for the learned
    backend's hard check (or None); ident numbers the requests of one caller. With `grasp` (a GraspSpec) the
    goal is a grasp: planned by planning/grasp.plan_grasp on the raw cloud (the target set aside there)."""

    q: np.ndarray
    goal: Goal
    scene: Any
    cloud: np.ndarray | None
    ident: int
    grasp: GraspSpec | None = None
    views: int = 1
    """cameras the cloud was fused from (the learned backend plans with its network from one only)"""
    eyes: np.ndarray | None = None
    """(K, 3) [m] those cameras' optical centres, if known (AMP-LS's escape searches space they saw first)"""


@dataclass(frozen=True)
class PlanOutcome:
    """The request and its result; result None with `error` set when the planner raised."""

    request: PlanRequest
    result: PlanResult | None
    error: str = ""
    wall_s: float = 0.0


PlanFn = Callable[[PlanRequest], PlanResult]


def planning_function(planner: Any, lock: threading.Lock | None = None, reachability: bool = True) -> PlanFn:
    """plan_fn for `planner` (AmpLs or an LSPP planner): with `reachability`, a goal no self- and table-collision-
    free IK solution takes is answered at once (planning/goal_reachability.py, reason "unreachable: ..."); else
    hands the raw cloud to a backend that hard-checks against it (learned) and plans; under `lock` when given."""
    lock = lock or threading.Lock()

    def plan(request: PlanRequest) -> PlanResult:
        with lock:
            t0 = time.perf_counter()
            why = unreachable_reason(planner.panda, planner.checker, request.goal, request.q) if reachability else ""
            if why:
                return refused_result(planner.panda, request.q, request.goal, f"unreachable: {why}", t0)
            if request.grasp is not None:
                cloud = request.cloud if request.cloud is not None else request.scene
                if cloud is None:
                    return refused_result(planner.panda, request.q, request.goal, "a grasp goal needs a cloud", t0)
                return plan_grasp_spec(planner, request.q, request.goal, np.asarray(cloud), request.grasp)
            backend = getattr(planner, "backend", None)
            if request.cloud is not None and backend is not None:
                backend.set_cloud(request.cloud, request.views)
            if request.eyes is not None and getattr(planner, "escape", None) is not None:
                return planner.plan(request.q, request.goal, request.scene, eyes=request.eyes)
            return planner.plan(request.q, request.goal, request.scene)

    return plan


def _run(plan_fn: PlanFn, request: PlanRequest) -> PlanOutcome:
    t0 = time.perf_counter()
    try:
        result, error = plan_fn(request), ""
    except Exception as err:  # a planner bug must not kill the worker; the loop reports it and goes on locally
        result, error = None, f"{type(err).__name__}: {err}"
    return PlanOutcome(request, result, error, time.perf_counter() - t0)


class ThreadedPlanRunner:
    """Plans on one daemon worker thread, newest request first; `poll` never blocks for long."""

    def __init__(self, plan_fn: PlanFn):
        self._fn = plan_fn
        self._cv = threading.Condition()
        self._pending: PlanRequest | None = None
        self._running = False
        self._done: PlanOutcome | None = None
        self._closed = False
        self._thread = threading.Thread(target=self._work, name="plan-runner", daemon=True)
        self._thread.start()

    def submit(self, request: PlanRequest, now: float = 0.0) -> None:
        """Queue request (replacing one still waiting); now [s] is unused (same signature as the deferred runner)."""
        with self._cv:
            self._pending = request
            self._cv.notify()

    def poll(self, now: float = 0.0) -> PlanOutcome | None:
        """The newest finished outcome not yet returned, or None."""
        with self._cv:
            done, self._done = self._done, None
            return done

    @property
    def busy(self) -> bool:
        """A request is waiting or running."""
        with self._cv:
            return self._running or self._pending is not None

    def close(self, timeout_s: float = 1.0) -> None:
        """Stop the worker after the plan it runs (if any)."""
        with self._cv:
            self._closed = True
            self._cv.notify()
        self._thread.join(timeout_s)

    def _work(self) -> None:
        while True:
            with self._cv:
                while self._pending is None and not self._closed:
                    self._cv.wait()
                if self._closed:
                    return
                request, self._pending, self._running = self._pending, None, True
            assert request is not None  # the wait ends on a request or on close
            outcome = _run(self._fn, request)
            with self._cv:
                self._done, self._running = outcome, False


class DeferredPlanRunner:
    """Plans at once but releases the outcome only when the simulated clock has advanced by the plan's wall time:
    a closed loop ticking in simulated time sees a plan arrive as late as it would on a worker thread."""

    def __init__(self, plan_fn: PlanFn):
        self._fn = plan_fn
        self._ready: tuple[float, PlanOutcome] | None = None
        self.spent_s = 0.0  # wall time [s] of all plans so far (a bench subtracts it from the tick's time)

    def submit(self, request: PlanRequest, now: float) -> None:
        outcome = _run(self._fn, request)
        self.spent_s += outcome.wall_s
        self._ready = (now + outcome.wall_s, outcome)

    def poll(self, now: float) -> PlanOutcome | None:
        if self._ready is None or now < self._ready[0]:
            return None
        outcome, self._ready = self._ready[1], None
        return outcome

    @property
    def busy(self) -> bool:
        return self._ready is not None

    def close(self, timeout_s: float = 1.0) -> None:
        self._ready = None

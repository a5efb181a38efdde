"""Plan in a child process, so that a running plan never shares the control loop's interpreter.

ROS-free. In one process a background plan and the control loop take turns at Python's interpreter lock: the
plan's Python work (the RRT escape's state checks, the optimiser's bookkeeping) delays every tick while it runs.
Measured ROS-free by `bench background` on a two-core machine (docs/profiling.md, "Background plans in a
process"): the closed loop's step p99 was 27.8 ms with no plan beside it, 140.6 ms beside plans on a thread and
27.1 ms beside plans in a process.

`PlanProcess` owns one child process (multiprocessing, spawn: a fresh interpreter, no copy of the parent's ROS
threads). The child builds a planner from a picklable `PlanSpec` (rebuilding only when the spec changes, so a
parameter change sends a new spec and spawns nothing), then answers requests one at a time. `plan_fn(spec)` is a
PlanFn (planning/plan_runner.py) that sends a request and waits for its answer: ThreadedPlanRunner calls it on
its worker thread, which waits in the pipe without holding the interpreter lock. A child that dies (a crash in a
native library) is restarted at the next request; the request it was running fails with the reason.
"""

from __future__ import annotations

import multiprocessing
import os
import signal
import sys
import threading
from dataclasses import dataclass
from typing import Any

from latent_planner_ros.planning.amp_ls import AmpLsConfig
from latent_planner_ros.planning.plan_runner import PlanFn, PlanRequest, planning_function
from latent_planner_ros.planning.result import PlanResult


@dataclass(frozen=True)
class PlanSpec:
    """What the child builds its AMP-LS planner from: checkpoints ("" = the shipped ones), the collision backend's
    name (planning/backends.make_backend) and the planner's configuration."""

    config: AmpLsConfig
    backend: str
    collision_checkpoint: str = ""
    vae_checkpoint: str = ""
    reachability: bool = True
    """refuse at once a goal no collision-free IK solution takes (planning_function's check)"""


class PlanProcessError(RuntimeError):
    """The child process failed: it could not build the planner, or it exited while planning."""


@dataclass(frozen=True)
class _Raised:
    """The child's answer when building or planning raised: the error's type and text."""

    text: str


def build_plan_fn(spec: PlanSpec) -> PlanFn:
    """The child's PlanFn for spec: the planner built and warmed up (CheckpointError for a bad checkpoint)."""
    import torch

    from latent_planner_ros.models.vae_io import load_vae
    from latent_planner_ros.planning.amp_ls import AmpLs
    from latent_planner_ros.planning.backends import make_backend

    torch.set_num_threads(1)
    vae, _ = load_vae(spec.vae_checkpoint or None)
    planner = AmpLs(vae, make_backend(spec.backend, spec.collision_checkpoint), spec.config)
    planner.warm_up()
    return planning_function(planner, reachability=spec.reachability)


def _serve(conn: Any) -> None:
    """The child's loop: (spec, request) -> PlanResult (request None: build only, answer None); ends when the
    parent sends None or its end of the pipe closes."""
    spec: PlanSpec | None = None
    plan: PlanFn | None = None
    while True:
        try:
            message = conn.recv()
        except (EOFError, OSError):
            return
        if message is None:
            return
        wanted, request = message
        try:
            if plan is None or wanted != spec:
                plan, spec = None, None
                plan, spec = build_plan_fn(wanted), wanted
            answer: Any = None if request is None else plan(request)
        except Exception as err:  # the parent reports it as this request's error; the child serves on
            answer = _Raised(f"{type(err).__name__}: {err}")
        try:
            conn.send(answer)
        except (EOFError, OSError):
            return
        except Exception as err:  # an answer that does not pickle: nothing was written, so say why instead
            conn.send(_Raised(f"the plan's answer could not be sent: {type(err).__name__}: {err}"))


def _child_main(conn: Any) -> None:
    """The child process: serve, then exit without the interpreter's finalisation (nothing there needs it, and
    OMPL's bindings print spurious reference-leak reports at it). Ctrl-C in a terminal reaches the whole process
    group: the child leaves it to the parent, whose exit closes the pipe and so ends the child."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        _serve(conn)
    finally:
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(0)


class PlanProcess:
    """One child process that plans; thread-safe (requests are served one at a time, in the order they come)."""

    def __init__(self) -> None:
        self._ctx = multiprocessing.get_context("spawn")
        self._lock = threading.Lock()
        self._conn: Any = None
        self._process: Any = None
        self._closed = False
        self.restarts = 0
        """children started after the first (each after one exited)"""

    @property
    def pid(self) -> int | None:
        """The child's process id, or None before the first request or after close."""
        return None if self._process is None else self._process.pid

    def _start(self) -> None:
        if self._process is not None:
            self.restarts += 1
            self._stop(timeout_s=0.0)
        parent, child = self._ctx.Pipe()
        process = self._ctx.Process(target=_child_main, args=(child,), name="plan-process", daemon=True)
        process.start()
        child.close()  # the child's end lives in the child only: its exit closes the pipe for recv here
        self._conn, self._process = parent, process

    def call(self, spec: PlanSpec, request: PlanRequest | None) -> PlanResult | None:
        """Plan request with the planner of spec (request None: build it only); blocks until the answer.

        Raises PlanProcessError when the child cannot build the planner, when planning raised in it (the error's
        type and text), or when it exited (it is restarted at the next call).
        """
        with self._lock:
            if self._closed:
                raise PlanProcessError("the plan process is closed")
            if self._process is None or not self._process.is_alive():
                self._start()
            process, conn = self._process, self._conn
            try:
                conn.send((spec, request))
                answer = conn.recv()
            except (EOFError, OSError):  # BrokenPipeError is an OSError
                process.join(1.0)
                code = process.exitcode
                why = "was closed" if self._closed else f"exited (code {code}); it restarts at the next plan"
                raise PlanProcessError(f"the plan process {why}") from None
        if isinstance(answer, _Raised):
            raise PlanProcessError(answer.text)
        return answer

    def plan_fn(self, spec: PlanSpec) -> PlanFn:
        """A PlanFn that plans in the child with the planner of spec."""

        def plan(request: PlanRequest) -> PlanResult:
            result = self.call(spec, request)
            assert result is not None  # a request gets a result or raises
            return result

        return plan

    def prepare(self, spec: PlanSpec) -> threading.Thread:
        """Start the child and build the planner of spec on a daemon thread (returned), so the first plan does not
        wait for the child's imports; an error there is raised again by the first plan."""

        def build() -> None:
            try:
                self.call(spec, None)
            except PlanProcessError:
                pass

        thread = threading.Thread(target=build, name="plan-process-prepare", daemon=True)
        thread.start()
        return thread

    def _stop(self, timeout_s: float) -> None:
        process, conn = self._process, self._conn
        self._process, self._conn = None, None
        if conn is not None:
            try:
                conn.send(None)
            except (EOFError, OSError):
                pass
            conn.close()
        if process is not None:
            process.join(timeout_s)
            if process.is_alive():
                process.terminate()
                process.join(1.0)

    def close(self, timeout_s: float = 1.0) -> None:
        """End the child (after the plan it runs, or terminated after timeout_s [s]); later calls raise."""
        self._closed = True
        acquired = self._lock.acquire(timeout=timeout_s)
        try:
            self._stop(timeout_s=timeout_s if acquired else 0.0)
        finally:
            if acquired:
                self._lock.release()

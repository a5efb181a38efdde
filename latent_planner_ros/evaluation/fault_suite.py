"""The node suite of the fault-injection cases: which processes, started, killed and restarted one by one.

Without the sim (``with_sim=False``) the suite is the planner (and the scene_encoder for the learned
backend) on wall-clock time, and the probe (``evaluation.probes.fault_probe``) plays the arm and the camera, so faulty
``joint_states`` and ``camera/points`` come from one publisher, deterministically. With the sim the nodes
run on simulated time as in the launcher. Each node runs under its own :class:`Supervisor`, so one can be
killed (SIGKILL to its process group) and started again while the others keep running.

    plan = plan_fault_suite("configured")
    with FaultSuite(plan, log_path="out/faults_nodes.log") as suite:
        suite.start()                        # the probe first, then the nodes; waits for their status
        suite.kill("planner"); suite.restart("planner")
        suite.probe.set_goal(...)            # a FaultSession
"""

from __future__ import annotations

import os
import signal
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import TextIO

from latent_planner_ros.evaluation.conveyor_suite import collision_weights, configured_planner
from latent_planner_ros.processes.node_suite import SuiteError, suite_env, suite_specs
from latent_planner_ros.processes.supervisor import StartupError, Supervisor, describe_exit

STARTUP_TIMEOUT_S = 120.0
"""[s] longest wait for a node's first status (the planner loads torch and its checkpoints)."""
PLANNER_STATUS_HZ = 10.0
"""The planner reports every control tick's timing (tick_ms) at 10 Hz."""


@dataclass(frozen=True)
class FaultSuitePlan:
    """The processes of a fault-injection group.

    Attributes:
        nodes: node names in start order.
        params: node -> ``name:=value`` parameters after its params file.
        backend: the planner's collision backend.
        with_sim: the sim plays the robot (else the probe's fake arm and camera do, on wall-clock time).
        notes: what differs from the configured suite, and why.
    """

    nodes: tuple[str, ...]
    params: dict[str, list[str]]
    backend: str
    with_sim: bool
    notes: tuple[str, ...] = field(default_factory=tuple)


def choose_backend(backend: str = "configured", collision_checkpoint: str = "") -> tuple[str, tuple[str, ...]]:
    """(backend, notes): "configured" is config/planner.yaml's, with "geometric" standing in for a learned
    backend whose weights are not installed. Raises SuiteError for "learned" without weights."""
    configured, checkpoint = configured_planner()
    checkpoint = collision_checkpoint or checkpoint
    chosen = configured if backend == "configured" else backend
    if chosen not in ("geometric", "learned"):
        raise SuiteError(f"backend {backend!r}: expected configured, geometric or learned")
    if chosen == "learned" and not collision_weights(checkpoint).is_file():
        missing = collision_weights(checkpoint)
        if backend == "learned":
            raise SuiteError(f"the learned collision backend needs {missing}, which does not exist")
        return "geometric", (f"learned backend configured but {missing.name} is not installed: geometric instead",)
    return chosen, ()


def plan_fault_suite(
    backend: str = "configured", with_sim: bool = False, collision_checkpoint: str = ""
) -> FaultSuitePlan:
    """The suite of one group of cases.

    Args:
        backend: "configured", "geometric" or "learned" (see :func:`choose_backend`).
        with_sim: run the sim (empty scenario) instead of the probe's fake arm and camera.
        collision_checkpoint: collision checkpoint stem for the planner and the scene_encoder ("" = shipped).
    """
    chosen, notes = choose_backend(backend, collision_checkpoint)
    nodes = ("scene_encoder", "planner") if chosen == "learned" else ("planner",)
    params = {
        "planner": [f"amp_ls.collision_backend:={chosen}", f"status_rate_hz:={PLANNER_STATUS_HZ}", "enabled:=true"],
        "scene_encoder": ["status_rate_hz:=5.0"],
    }
    if collision_checkpoint:
        params["planner"].append(f"collision_checkpoint:={collision_checkpoint}")
        params["scene_encoder"].append(f"checkpoint:={collision_checkpoint}")
    if with_sim:
        nodes = ("sim", *nodes)
        params["sim"] = ["scenario:=empty", "real_time_factor:=1.0"]
    return FaultSuitePlan(nodes, {n: p for n, p in params.items() if n in nodes}, chosen, with_sim, notes)


class FaultSuite:
    """Runs a :class:`FaultSuitePlan` and the probe; a context manager.

    Args:
        plan: the processes.
        log_path: file for every node's prefixed output (None: this process's stdout/stderr).
        domain_id: ROS_DOMAIN_ID of the nodes and the probe; None keeps the environment's.
    """

    def __init__(self, plan: FaultSuitePlan, log_path: str | Path | None = None, domain_id: int | None = None):
        self.plan = plan
        self.domain_id = domain_id
        self._log: TextIO | None = None
        if log_path is not None:
            Path(log_path).parent.mkdir(parents=True, exist_ok=True)
            self._log = open(log_path, "a", buffering=1)  # noqa: SIM115 (closed in stop())
        env = suite_env(domain_id, headless=True)
        specs = suite_specs(plan.nodes, plan.params, env, use_sim_time=plan.with_sim)
        self.specs = {s.name: s for s in specs}
        self.running: dict[str, Supervisor] = {}
        self.killed: set[str] = set()
        self.probe = None

    def log(self, message: str) -> None:
        line = f"[faults] {message}\n"
        if self._log is not None:
            self._log.write(line)

    def start(self) -> float:
        """Start the probe and every node; returns the start-up time [s]. Raises StartupError."""
        from latent_planner_ros.evaluation.probes.fault_probe import FaultSession

        t0 = time.monotonic()
        self.probe = FaultSession(self.domain_id, fake_arm=not self.plan.with_sim)
        for name in self.plan.nodes:
            self._launch(name)
        self.wait_up(self.plan.nodes, since=t0)
        return time.monotonic() - t0

    def _launch(self, name: str) -> None:
        sup = Supervisor([self.specs[name]], stdout=self._log, stderr=self._log, label="faults")
        sup.start()
        self.running[name] = sup
        self.killed.discard(name)

    def _up(self, name: str, since: float) -> bool:
        if name == "sim":
            return any(t >= since for t, _ in self.probe.measured_since(since))
        return bool(self.probe.statuses_since(name, since))

    def wait_up(self, names, since: float, timeout_s: float = STARTUP_TIMEOUT_S) -> None:
        """Wait until every node in `names` was heard from after `since` (status, or the sim's joint_states)."""
        end = time.monotonic() + timeout_s
        pending = list(names)
        while pending:
            for name in pending:
                code = self.running[name].exited().get(name)
                if code is not None:
                    tail = "\n".join(self.running[name].tail(name)[-10:])
                    raise StartupError(name, f"node {name} exited with {describe_exit(code)} during start-up:\n{tail}")
            pending = [n for n in pending if not self._up(n, since)]
            if pending and time.monotonic() > end:
                raise StartupError(pending[0], f"node {pending[0]} not up after {timeout_s:g} s")
            time.sleep(0.1)

    def kill(self, name: str) -> None:
        """SIGKILL the node's process group (as a crash would end it) and wait for it."""
        sup = self.running[name]
        pid = sup.pids[name]
        self.killed.add(name)
        try:
            os.killpg(pid, signal.SIGKILL)
        except ProcessLookupError:
            pass
        sup.stop(sigint_timeout_s=0.0, sigterm_timeout_s=0.0)
        self.log(f"killed {name} (pid {pid})")

    def restart(self, name: str, timeout_s: float = STARTUP_TIMEOUT_S) -> float:
        """Start a killed node again and wait for its first status; returns the time it took [s]."""
        t0 = time.monotonic()
        self._launch(name)
        self.wait_up([name], since=t0, timeout_s=timeout_s)
        self.log(f"restarted {name} in {time.monotonic() - t0:.1f} s")
        return time.monotonic() - t0

    def crashed(self) -> dict[str, str]:
        """Nodes that ended without being killed on purpose: name -> how they ended."""
        out = {}
        for name, sup in self.running.items():
            code = sup.exited().get(name)
            if code is not None and name not in self.killed:
                out[name] = describe_exit(code)
        return out

    def tail(self, name: str) -> list[str]:
        return self.running[name].tail(name) if name in self.running else []

    def stop(self) -> dict[str, int]:
        """Stop the probe and the nodes; returns the nodes' exit codes (SIGINT first: 0 is a clean stop)."""
        if self.probe is not None:
            self.probe.close()
            self.probe = None
        codes = {}
        for sup in self.running.values():
            codes.update(sup.stop())
        if self._log is not None:
            self._log.close()
            self._log = None
        return codes

    def __enter__(self) -> FaultSuite:
        return self

    def __exit__(self, *exc) -> None:
        self.stop()

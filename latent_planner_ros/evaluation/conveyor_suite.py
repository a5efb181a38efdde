"""The conveyor scenario through the real node suite: the engine shared by ``demo`` and ``bench conveyor``.

The suite is the launcher's (``node_suite`` + ``Supervisor``): ``sim`` with the conveyor scenario,
``scene_encoder`` when the planner uses the learned collision backend, and ``planner`` with its goal
remapped to the sim's moving target (``-r goal_pose:=target_pose``), each a process with its
``config/<node>.yaml`` and ``use_sim_time``. The planner starts disabled; a trial disables it, sets the
sim's ``seed``/``scenario_overrides`` if asked, resets the scene, lets it run ``settle_s``, enables the
planner and records ``duration_s`` of simulated time with the ``trial_monitor`` node.

    plan = plan_suite()                                 # nodes and parameters from the config defaults
    with ConveyorSuite(plan, log_path="out/nodes.log") as suite:
        suite.start()
        log = suite.run_trial(30.0)                     # a ROS-free TrialLog
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TextIO

import yaml

from latent_planner_ros.evaluation.trial import TrialLog
from latent_planner_ros.processes.node_suite import SuiteError, find_params_file, suite_env, suite_specs
from latent_planner_ros.processes.supervisor import StartupError, Supervisor, describe_exit

SCENARIO = "conveyor"
STARTUP_TIMEOUT_S = 120.0
"""[s] longest wait for the suite to come up (the planner loads torch and its checkpoints)."""
STALL_TIMEOUT_S = 20.0
"""[s] of wall-clock time without simulated time advancing after which the sim counts as stalled."""


@dataclass(frozen=True)
class SuitePlan:
    """The processes of a conveyor run.

    Attributes:
        nodes: node names in start order.
        params: node -> ``name:=value`` parameters after its params file.
        ros_args: node -> further ROS arguments (the planner's goal remapping).
        backend: the planner's collision backend ("geometric" or "learned").
        configured_backend: what config/planner.yaml asks for.
        seed: the sim's scenario seed.
        real_time_factor: the sim's pace (simulated s per wall s; 0 = as fast as possible).
        notes: what differs from the full suite, and why (printed for the user).
    """

    nodes: tuple[str, ...]
    params: dict[str, list[str]]
    ros_args: dict[str, list[str]]
    backend: str
    configured_backend: str
    seed: int
    real_time_factor: float
    notes: tuple[str, ...] = field(default_factory=tuple)


def configured_planner() -> tuple[str, str]:
    """(collision_backend, collision_checkpoint) of the planner's params file (dataclass defaults where absent)."""
    from latent_planner_ros.planning.amp_ls import AmpLsConfig

    backend, checkpoint = AmpLsConfig().collision_backend, ""
    path = find_params_file("planner")
    if path is not None:
        params = (yaml.safe_load(path.read_text()) or {}).get("planner", {}).get("ros__parameters", {})
        backend = params.get("amp_ls", {}).get("collision_backend", backend)
        checkpoint = params.get("collision_checkpoint", checkpoint) or ""
    return backend, checkpoint


def collision_weights(checkpoint: str = "") -> Path:
    """The ``.safetensors`` file of a collision checkpoint stem ("" = the shipped one)."""
    from latent_planner_ros.models.collision_io import shipped_collision_path

    stem = Path(checkpoint) if checkpoint else shipped_collision_path()
    return stem.with_name(stem.name + ".safetensors")


def plan_suite(
    backend: str | None = None,
    seed: int = 0,
    real_time_factor: float = 1.0,
    status_rate_hz: float = 10.0,
    planner_set: Sequence[str] = (),
) -> SuitePlan:
    """The suite for a conveyor run.

    Args:
        backend: the planner's collision backend; None = config/planner.yaml's. When the configured backend is
            "learned" but its weights are not installed, "geometric" stands in (with a note); asking for
            "learned" explicitly then raises SuiteError.
        seed: the sim's scenario seed (target and obstacle layout).
        real_time_factor: the sim's pace.
        status_rate_hz: the planner's status rate (10 Hz reports about every control tick's timing).
        planner_set: "NAME=VALUE" planner parameters on top of config/planner.yaml (SuiteError if malformed; a
            bad value makes the planner refuse to start, which the suite reports).
    """
    configured, checkpoint = configured_planner()
    chosen = backend or configured
    notes = []
    if chosen == "learned" and not collision_weights(checkpoint).is_file():
        missing = collision_weights(checkpoint)
        if backend == "learned":
            raise SuiteError(f"the learned collision backend needs {missing}, which does not exist")
        notes.append(
            f"config/planner.yaml selects the learned collision backend, but its weights ({missing.name}) are not "
            "installed: the planner runs with the geometric backend instead"
        )
        chosen = "geometric"
    if chosen != "learned":
        notes.append(
            f"scene_encoder not started: the planner's collision backend is {chosen!r}, which reads camera/points "
            "directly (no scene embeddings needed)"
        )
    nodes = ("sim", "scene_encoder", "planner") if chosen == "learned" else ("sim", "planner")
    planner_params = ["enabled:=false", f"status_rate_hz:={float(status_rate_hz)}"]
    if chosen != configured:
        planner_params.append(f"amp_ls.collision_backend:={chosen}")
    for item in planner_set:
        name, sep, value = item.partition("=")
        if not sep or not name.strip() or not value.strip() or ":=" in item:
            raise SuiteError(f"planner parameter {item!r} is not NAME=VALUE (e.g. closed_loop.goal_lead_s=0.5)")
        planner_params.append(f"{name.strip()}:={value.strip()}")
    return SuitePlan(
        nodes=nodes,
        params={
            "sim": [f"scenario:={SCENARIO}", f"seed:={int(seed)}", f"real_time_factor:={float(real_time_factor)}"],
            "planner": planner_params,
        },
        ros_args={"planner": ["-r", "goal_pose:=target_pose"]},
        backend=chosen,
        configured_backend=configured,
        seed=int(seed),
        real_time_factor=float(real_time_factor),
        notes=tuple(notes),
    )


class SuiteFailed(RuntimeError):
    """A node died or the simulation stalled during a run.

    Attributes:
        name: the node at fault; tail: its last output lines.
    """

    def __init__(self, name: str, message: str, tail: list[str] | None = None):
        super().__init__(message)
        self.name = name
        self.tail = tail or []


Progress = Callable[[float, object], None]
"""progress(trial time [s], monitor snapshot) during a trial."""


class ConveyorSuite:
    """Starts the suite of a :class:`SuitePlan`, runs trials, stops it (a context manager).

    Args:
        plan: the processes.
        log_path: file for every node's (prefixed) output; None echoes it to this process's stdout/stderr.
        domain_id: ROS_DOMAIN_ID of the suite and the monitor; None keeps the environment's.
        startup_timeout_s: longest wait [s] for every node to be up.
    """

    def __init__(
        self,
        plan: SuitePlan,
        log_path: str | Path | None = None,
        domain_id: int | None = None,
        startup_timeout_s: float = STARTUP_TIMEOUT_S,
    ):
        self.plan = plan
        self.domain_id = domain_id
        self.startup_timeout_s = startup_timeout_s
        self._log_file: TextIO | None = None
        if log_path is not None:
            Path(log_path).parent.mkdir(parents=True, exist_ok=True)
            self._log_file = open(log_path, "w", buffering=1)  # noqa: SIM115 (closed in stop())
        env = suite_env(domain_id, headless=True)
        specs = suite_specs(plan.nodes, plan.params, env, ros_args=plan.ros_args)
        self.supervisor = Supervisor(specs, stdout=self._log_file, stderr=self._log_file, label="suite")
        self.monitor = None

    def start(self, stop: threading.Event | None = None) -> float:
        """Start the nodes and wait until they are up and the clock runs; returns the start-up time [s].

        Raises:
            StartupError: naming the node that died or was not up in time.
        """
        from latent_planner_ros.evaluation.probes.graph_probe import GraphProbe
        from latent_planner_ros.evaluation.probes.trial_monitor import MonitorSession

        t0 = time.monotonic()
        self.supervisor.start()
        with GraphProbe(domain_id=self.domain_id) as probe:
            if not self.supervisor.wait_ready(probe.ready_nodes, self.startup_timeout_s, stop):
                raise KeyboardInterrupt
        self.monitor = MonitorSession(self.domain_id)
        self.monitor.wait_clock()
        return time.monotonic() - t0

    def check(self) -> None:
        """Raise SuiteFailed if a node has exited."""
        for name, code in self.supervisor.exited().items():
            raise SuiteFailed(name, f"node {name} exited with {describe_exit(code)}", self.supervisor.tail(name))

    def _wait_sim_time(self, until: float, progress: Callable[[float], None] | None = None) -> float:
        """Block until simulated time reaches `until` [s]; returns the clock. Calls progress(clock) ~2x/s."""
        last_clock, last_change, last_report = None, time.monotonic(), 0.0
        while True:
            self.check()
            clock = self.monitor.clock()
            now = time.monotonic()
            if clock != last_clock:
                last_clock, last_change = clock, now
            elif now - last_change > STALL_TIMEOUT_S:
                raise SuiteFailed("sim", f"simulated time stopped at {clock:.2f} s for {STALL_TIMEOUT_S:g} s")
            if clock is not None and clock >= until:
                return clock
            if progress is not None and now - last_report >= 0.5:
                last_report = now
                progress(clock)
            time.sleep(0.02)

    def run_trial(
        self,
        duration_s: float,
        seed: int | None = None,
        overrides: str | None = None,
        settle_s: float = 0.5,
        progress: Progress | None = None,
    ) -> TrialLog:
        """One trial: new scene (optionally another seed / scenario_overrides), then duration_s [s] of tracking.

        Raises:
            SuiteFailed: a node died or the simulation stalled; RuntimeError: a parameter or reset was refused.
        """
        m = self.monitor
        m.enable_planner(False)
        values = {}
        if seed is not None:
            values["seed"] = int(seed)
        if overrides is not None:
            values["scenario_overrides"] = overrides
        if values:
            m.set_sim_parameters(**values)
        m.reset_sim()
        self._wait_sim_time(m.clock() + settle_s)
        if m.node.scenario_start is None:  # not a single joint state since the reset
            raise SuiteFailed("sim", f"no joint_states within {settle_s:g} s of simulated time after sim/reset")
        m.enable_planner(True)
        t0 = m.begin()

        def report(clock: float) -> None:
            if progress is not None:
                progress(clock - t0, m.snapshot())

        try:
            self._wait_sim_time(t0 + duration_s, report)
        finally:
            log = m.end(duration_s)
        if progress is not None:
            progress(duration_s, m.snapshot())
        m.enable_planner(False)
        return log

    def stop(self) -> dict[str, int]:
        """Stop the monitor and every node; returns the nodes' exit codes."""
        if self.monitor is not None:
            self.monitor.close()
            self.monitor = None
        codes = self.supervisor.stop()
        if self._log_file is not None:
            self._log_file.close()
            self._log_file = None
        return codes

    def __enter__(self) -> ConveyorSuite:
        return self

    def __exit__(self, *exc) -> None:
        self.stop()


__all__ = ["ConveyorSuite", "StartupError", "SuiteFailed", "SuitePlan", "configured_planner", "plan_suite"]

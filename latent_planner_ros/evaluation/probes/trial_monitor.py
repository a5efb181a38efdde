"""trial_monitor: a node that logs a closed-loop trial and drives the suite between trials.

Subscribes ``/clock``, ``joint_states``, ``target_pose``, ``sim/in_collision``, ``sim/min_distance``,
``joint_command`` and ``planner/status``; calls ``sim/reset``, ``sim/set_parameters`` and ``planner/enable``.
:class:`MonitorSession` runs it in its own rclpy context on a background thread (no signal handlers), so the
demo and the benchmark keep their own Ctrl-C handling and call it from their main thread:

    with MonitorSession(domain_id) as monitor:
        monitor.reset_sim(seed=3, overrides="{speed: 0.08}")
        monitor.enable_planner(True)
        monitor.begin()
        ...                                  # monitor.clock() advances with the simulation
        log = monitor.end(duration_s=10.0)   # a ROS-free TrialLog
"""

from __future__ import annotations

import math
import threading
import time
from dataclasses import dataclass, field

import numpy as np
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import PoseStamped
from rcl_interfaces.srv import SetParameters
from rclpy.node import Node
from rclpy.parameter import Parameter
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import JointState
from std_msgs.msg import Bool, Float64
from std_srvs.srv import SetBool, Trigger

from latent_planner_ros.evaluation.probes.probe_session import ProbeSession
from latent_planner_ros.evaluation.trial import TrialLog
from msg_adapters import AdapterError, joint_state_to_q, pose_stamped_to_target

JOINT_PERIOD_S = 0.01
"""[s] the sim's joint-state period (its first message after a reset is one period into the new scene)."""


def _seconds(stamp) -> float:
    return stamp.sec + stamp.nanosec * 1e-9


@dataclass
class _Series:
    """Samples received while recording, as lists of (time [s], value)."""

    joints: list = field(default_factory=list)
    targets: list = field(default_factory=list)
    contact: list = field(default_factory=list)
    distance: list = field(default_factory=list)
    status: list = field(default_factory=list)
    commands: list = field(default_factory=list)


@dataclass
class Live:
    """The latest values, for a status line. Times [s] of simulated time; None until received."""

    clock: float | None = None
    q: np.ndarray | None = None
    target_position: np.ndarray | None = None
    state: str = "no status yet"
    tick_ms: float = math.nan
    contacts: int = 0
    source: str = ""
    """where the planner's last command came from: "plan" (a background plan followed), "local" (a latent step),
    "wait", "hold" or "" (status `command_source`)"""


class TrialMonitor(Node):
    """Logs the time series of :class:`~latent_planner_ros.evaluation.trial.TrialLog` while recording.

    Args:
        sim, planner: the names (namespaces of the services and status topic) of the sim and planner nodes.
    """

    def __init__(self, sim: str = "sim", planner: str = "planner", **kwargs):
        super().__init__("trial_monitor", start_parameter_services=False, **kwargs)
        self._lock = threading.Lock()
        self.live = Live()
        self._series: _Series | None = None
        self._last_joint_stamp = -math.inf
        self._was_in_contact = False
        self._await_scenario_start = False
        self.scenario_start: float | None = None
        self.create_subscription(Clock, "/clock", self._on_clock, 10)
        self.create_subscription(JointState, "joint_states", self._on_joints, 100)
        self.create_subscription(PoseStamped, "target_pose", self._on_target, 20)
        self.create_subscription(Bool, f"{sim}/in_collision", self._on_contact, 100)
        self.create_subscription(Float64, f"{sim}/min_distance", self._on_distance, 100)
        self.create_subscription(JointState, "joint_command", self._on_command, 50)
        self.create_subscription(DiagnosticArray, f"{planner}/status", self._on_status, 20)
        self.reset_client = self.create_client(Trigger, f"{sim}/reset")
        self.sim_params_client = self.create_client(SetParameters, f"{sim}/set_parameters")
        self.enable_client = self.create_client(SetBool, f"{planner}/enable")

    # -- callbacks (executor thread) -----------------------------------------------------------------
    def _on_clock(self, msg: Clock) -> None:
        with self._lock:
            self.live.clock = _seconds(msg.clock)

    def _on_joints(self, msg: JointState) -> None:
        try:
            q, _ = joint_state_to_q(msg)
        except AdapterError:
            return
        t = _seconds(msg.header.stamp)
        with self._lock:
            self._last_joint_stamp = t
            self.live.q = q
            if self._await_scenario_start:
                self._await_scenario_start = False
                self.scenario_start = t - JOINT_PERIOD_S
            if self._series is not None:
                self._series.joints.append((t, q))

    def _on_target(self, msg: PoseStamped) -> None:
        try:
            target = pose_stamped_to_target(msg)
        except AdapterError:
            return
        with self._lock:
            self.live.target_position = np.array(target.position)
            if self._series is not None:
                self._series.targets.append(
                    (_seconds(msg.header.stamp), np.array(target.position), np.array(target.quaternion_xyzw))
                )

    # sim/in_collision and sim/min_distance carry no stamp: the sim publishes them right after joint_states.
    def _on_contact(self, msg: Bool) -> None:
        with self._lock:
            if self._series is not None:
                if msg.data and not self._was_in_contact:
                    self.live.contacts += 1
                self._series.contact.append((self._last_joint_stamp, bool(msg.data)))
            self._was_in_contact = bool(msg.data)

    def _on_distance(self, msg: Float64) -> None:
        with self._lock:
            if self._series is not None:
                self._series.distance.append((self._last_joint_stamp, float(msg.data)))

    def _on_command(self, msg: JointState) -> None:
        with self._lock:
            if self._series is not None:
                self._series.commands.append(_seconds(msg.header.stamp))

    def _on_status(self, msg: DiagnosticArray) -> None:
        for status in msg.status:
            values = {kv.key: kv.value for kv in status.values}
            try:
                tick_ms = float(values.get("tick_ms", "nan"))
            except ValueError:
                tick_ms = math.nan
            state = values.get("state", status.message.split(":")[0])
            with self._lock:
                self.live.state, self.live.tick_ms = state, tick_ms
                self.live.source = values.get("command_source", "")
                if self._series is not None:
                    self._series.status.append(
                        (
                            _seconds(msg.header.stamp),
                            state,
                            tick_ms,
                            status.message,
                            self.live.source,
                            values.get("servo_note", ""),
                        )
                    )

    # -- recording (any thread) ----------------------------------------------------------------------
    def begin(self) -> float:
        """Start a new recording; returns its start time t0 [s] (the latest /clock, or joint stamp)."""
        with self._lock:
            self._series = _Series()
            self.live.contacts = 0
            t0 = self.live.clock if self.live.clock is not None else self._last_joint_stamp
            self._t0 = t0 if math.isfinite(t0) else 0.0
            return self._t0

    def end(self, duration_s: float, command_period_s: float = 0.1) -> TrialLog:
        """Stop recording; the samples up to t0 + duration_s as a TrialLog (times relative to t0)."""
        with self._lock:
            s, self._series = self._series, None
            t0 = self._t0
            start = self.scenario_start
        if s is None:
            raise RuntimeError("end() without begin()")
        end = t0 + duration_s + 1e-6

        def times(rows, k=0):
            return np.array([r[k] for r in rows if r[0] <= end], dtype=float).reshape(-1) - t0

        def values(rows, k, shape, dtype=float):
            return np.array([r[k] for r in rows if r[0] <= end], dtype=dtype).reshape(-1, *shape)

        commands = np.array([c for c in s.commands if c <= end], dtype=float) - t0
        status = [r for r in s.status if r[0] <= end]
        return TrialLog(
            duration_s=float(duration_s),
            joint_t=times(s.joints),
            q=values(s.joints, 1, (7,)),
            target_t=times(s.targets),
            target_position=values(s.targets, 1, (3,)),
            target_quaternion=values(s.targets, 2, (4,)),
            contact_t=times(s.contact),
            contact=values(s.contact, 1, (), dtype=bool),
            distance_t=times(s.distance),
            distance=values(s.distance, 1, ()),
            status_t=np.array([r[0] for r in status], dtype=float) - t0,
            status_state=tuple(r[1] for r in status),
            status_message=tuple(r[3] for r in status),
            status_source=tuple(r[4] for r in status),
            status_servo_note=tuple(r[5] for r in status),
            tick_ms=np.array([r[2] for r in status], dtype=float),
            command_t=commands,
            command_period_s=command_period_s,
            scenario_start_s=(start - t0) if start is not None else 0.0,
        )

    def snapshot(self) -> Live:
        """A copy of the latest values."""
        with self._lock:
            return Live(**vars(self.live))

    def expect_scenario_start(self) -> None:
        """The next joint_states message is the first of a new scene (call right after sim/reset answered)."""
        with self._lock:
            self.scenario_start = None
            self._await_scenario_start = True


class MonitorSession(ProbeSession):
    """A :class:`TrialMonitor` in its own context, spun on a background thread; service calls block.

    Args:
        domain_id: the ROS domain; None uses ``$ROS_DOMAIN_ID``.
    """

    def __init__(self, domain_id: int | None = None):
        super().__init__(lambda context: TrialMonitor(context=context), "trial_monitor", domain_id)

    def set_sim_parameters(self, **values) -> None:
        """Set sim parameters (e.g. seed=3, scenario_overrides="{speed: 0.1}"); RuntimeError if refused."""
        params = [Parameter(name, value=value).to_parameter_msg() for name, value in values.items()]
        response = self.call(self.node.sim_params_client, SetParameters.Request(parameters=params))
        for name, result in zip(values, response.results, strict=True):
            if not result.successful:
                raise RuntimeError(f"sim refused {name}={values[name]!r}: {result.reason}")

    def reset_sim(self) -> str:
        """Reload the sim's scenario (sim/reset); returns its message, RuntimeError if it failed."""
        response = self.call(self.node.reset_client, Trigger.Request())
        if not response.success:
            raise RuntimeError(f"sim/reset failed: {response.message}")
        self.node.expect_scenario_start()
        return response.message

    def enable_planner(self, enabled: bool) -> None:
        """Switch the planner's closed-loop tracking (planner/enable)."""
        response = self.call(self.node.enable_client, SetBool.Request(data=enabled))
        if not response.success:
            raise RuntimeError(f"planner/enable refused: {response.message}")

    # -- convenience ---------------------------------------------------------------------------------
    def clock(self) -> float | None:
        """The latest simulated time [s], or None before the first /clock."""
        return self.node.snapshot().clock

    def wait_clock(self, timeout_s: float = 30.0) -> float:
        """Wait for the first /clock; TimeoutError if none comes."""
        end = time.monotonic() + timeout_s
        while (t := self.clock()) is None:
            if time.monotonic() > end:
                raise TimeoutError(f"no /clock within {timeout_s:g} s")
            time.sleep(0.05)
        return t

    def begin(self) -> float:
        return self.node.begin()

    def end(self, duration_s: float, command_period_s: float = 0.1) -> TrialLog:
        return self.node.end(duration_s, command_period_s)

    def snapshot(self) -> Live:
        return self.node.snapshot()

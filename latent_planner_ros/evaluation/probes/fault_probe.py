"""fault_probe: the node that injects faults into the suite and watches the safety invariant.

Two modes:

- ``fake_arm=True`` (no sim): the probe is the robot and its camera. A kinematic arm follows ``joint_command``
  through the sim's command interface (``sim_bridge.command.JointCommand``: clamped, linear over 0.1 s, at most
  V_MAX, holding after 1 s without commands) and publishes ``joint_states`` at 100 Hz; a camera thread
  publishes ``camera/points``. Both can be replaced by faulty messages or silenced. The safety monitor
  checks commands against the arm's true state, whatever the probe publishes.
- ``fake_arm=False`` (with the sim): the monitor's measured state is the sim's ``joint_states``.

In both it republishes the current goal at 2 Hz (a goal source such as the sim's ``target_pose`` does),
records ``joint_command``, ``planner/status``, ``scene_encoder/status`` and ``/rosout``, and calls parameter,
enable and reset services. :class:`FaultSession` runs it in its own rclpy context on background threads.
"""

from __future__ import annotations

import struct
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import PoseStamped
from rcl_interfaces.msg import Log
from rcl_interfaces.srv import SetParameters
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import DurabilityPolicy, QoSProfile
from rclpy.serialization import serialize_message
from sensor_msgs.msg import JointState, PointCloud2
from std_srvs.srv import SetBool, Trigger

from latent_planner_ros.evaluation.probes.probe_session import ProbeSession
from latent_planner_ros.evaluation.safety import SafetyConfig, SafetyMonitor, Violation, command_positions
from latent_planner_ros.robot.limits import Q_READY
from msg_adapters import AdapterError, joint_state_to_q, q_to_joint_state
from sim_bridge.command import JointCommand

ARM_RATE_HZ = 100.0
GOAL_RATE_HZ = 2.0

JointFault = Callable[[np.ndarray], JointState | None]
"""Maps the arm's true q (7,) to the joint_states message to publish instead, or None to publish nothing."""


@dataclass(frozen=True)
class Status:
    """One DiagnosticStatus as received: time [s] (monotonic), level, message, key-values."""

    t: float
    level: int
    message: str
    values: dict

    def text(self) -> str:
        return f"{self.message} | " + " ".join(f"{k}={v}" for k, v in self.values.items())


class FaultProbe(Node):
    """See the module docstring. Times are time.monotonic() seconds.

    Args:
        fake_arm: be the robot and camera (True), or watch the sim's joint_states (False).
        safety: bounds of the invariant.
    """

    def __init__(self, fake_arm: bool = True, safety: SafetyConfig | None = None, **kwargs):
        super().__init__("fault_probe", start_parameter_services=False, **kwargs)
        self.fake_arm = fake_arm
        self.lock = threading.RLock()
        self.safety = SafetyMonitor(safety)
        self.commands: list[tuple[float, np.ndarray | None, float]] = []  # (received, q, header stamp [s])
        self.violations: list[Violation] = []
        self.statuses: dict[str, list[Status]] = {}
        self.logs: list[tuple[float, str, int, str]] = []
        self.measured: list[tuple[float, np.ndarray]] = []
        self.clouds_published: list[float] = []
        self.joint_fault: JointFault | None = None
        self.goal: PoseStamped | None = None
        self.cloud: bytearray | None = None  # the camera's cloud, serialized
        self.cloud_rate_hz = 10.0
        self.arm = JointCommand(Q_READY, period=0.1, timeout=1.0) if fake_arm else None

        self.pub_joints = self.create_publisher(JointState, "joint_states", 10)
        self.pub_cloud = self.create_publisher(PointCloud2, "camera/points", 2)
        self.pub_goal = self.create_publisher(PoseStamped, "goal_pose", 10)
        self.create_subscription(JointState, "joint_command", self._on_command, 50)
        if not fake_arm:
            self.create_subscription(JointState, "joint_states", self._on_joint_states, 100)
        for name in ("planner", "scene_encoder"):
            self.create_subscription(DiagnosticArray, f"{name}/status", lambda msg, n=name: self._on_status(n, msg), 50)
        rosout_qos = QoSProfile(depth=200, durability=DurabilityPolicy.TRANSIENT_LOCAL)  # as rcl publishes it
        self.create_subscription(Log, "/rosout", self._on_log, rosout_qos)
        self.create_timer(1.0 / GOAL_RATE_HZ, self._publish_goal)
        self.param_clients = {
            n: self.create_client(SetParameters, f"{n}/set_parameters") for n in ("planner", "scene_encoder", "sim")
        }
        self.enable_client = self.create_client(SetBool, "planner/enable")
        self.reset_client = self.create_client(Trigger, "sim/reset")

    # -- callbacks ---------------------------------------------------------------------------------
    def _on_command(self, msg: JointState) -> None:
        t = time.monotonic()
        with self.lock:
            found = self.safety.on_command(t, msg.name, msg.position)
            self.violations += found
            try:
                q = command_positions(msg.name, msg.position)
            except ValueError:
                q = None
            self.commands.append((t, q, msg.header.stamp.sec + msg.header.stamp.nanosec * 1e-9))
            if self.arm is not None and q is not None and np.all(np.isfinite(q)):
                self.arm.set(q, t)

    def _on_joint_states(self, msg: JointState) -> None:
        try:
            q, _ = joint_state_to_q(msg)
        except AdapterError:
            return
        t = time.monotonic()
        with self.lock:
            self.safety.on_state(t, q)
            self.measured.append((t, q))

    def _on_status(self, name: str, msg: DiagnosticArray) -> None:
        t = time.monotonic()
        with self.lock:
            for s in msg.status:
                values = {kv.key: kv.value for kv in s.values}
                self.statuses.setdefault(name, []).append(Status(t, s.level[0], s.message, values))

    def _on_log(self, msg: Log) -> None:
        with self.lock:
            self.logs.append((time.monotonic(), msg.name, int(msg.level), msg.msg))

    def _publish_goal(self) -> None:
        with self.lock:
            goal = self.goal
        if goal is not None:
            self.pub_goal.publish(goal)

    # -- the fake arm and camera (own threads) -----------------------------------------------------------
    def step_arm(self, dt: float) -> None:
        """Advance the fake arm by dt [s] and publish its joint state (or the fault's message, or nothing)."""
        t = time.monotonic()
        with self.lock:
            q = self.arm.advance(t, dt).copy()
            self.safety.on_state(t, q)
            self.measured.append((t, q))
            fault = self.joint_fault
        msg = q_to_joint_state(q) if fault is None else fault(q)
        if msg is not None:
            msg.header.stamp = self.get_clock().now().to_msg()
            self.pub_joints.publish(msg)

    def set_cloud(self, cloud: PointCloud2 | None, rate_hz: float | None = None) -> None:
        """Serialize the cloud once (a 100k-point cloud takes ~30 ms, which at 30 Hz would load the probe, not
        the nodes); each publication only writes its stamp into the bytes."""
        data = None
        if cloud is not None:
            data = bytearray(serialize_message(cloud))
            if data[:2] != b"\x00\x01":  # CDR little-endian: header.stamp (int32 sec, uint32 nanosec) at 4..12
                raise ValueError(f"unexpected CDR encapsulation {bytes(data[:4]).hex()}")
        with self.lock:
            self.cloud = data
            if rate_hz is not None:
                self.cloud_rate_hz = float(rate_hz)

    def publish_cloud(self) -> float:
        """Publish the current cloud (if any) with a fresh stamp; returns the camera period [s]."""
        with self.lock:
            data, rate = self.cloud, self.cloud_rate_hz
        if data is not None:
            ns = self.get_clock().now().nanoseconds
            struct.pack_into("<iI", data, 4, ns // 1_000_000_000, ns % 1_000_000_000)
            self.pub_cloud.publish(bytes(data))
            with self.lock:
                self.clouds_published.append(time.monotonic())
        return 1.0 / rate


class FaultSession(ProbeSession):
    """A :class:`FaultProbe` in its own context: an executor thread, and (fake arm) arm and camera threads.

    Args:
        domain_id: the ROS domain; None uses ``$ROS_DOMAIN_ID``.
        fake_arm: see FaultProbe.
    """

    def __init__(self, domain_id: int | None = None, fake_arm: bool = True, safety: SafetyConfig | None = None):
        loops = (("fault_probe_arm", self._arm_loop), ("fault_probe_camera", self._camera_loop)) if fake_arm else ()

        def make(context):
            return FaultProbe(fake_arm=fake_arm, safety=safety, context=context)

        super().__init__(make, "fault_probe", domain_id, loops)

    def _loop(self, step: Callable[[], float]) -> None:
        next_t = time.monotonic()
        while not self._stop.is_set():
            try:
                period = step()
            except Exception:  # the context went down while stopping
                if self._stop.is_set() or not self.context.ok():
                    return
                raise
            next_t = max(next_t + period, time.monotonic() - period)  # no burst after a stall
            self._stop.wait(max(0.0, next_t - time.monotonic()))

    def _arm_loop(self) -> None:
        dt = 1.0 / ARM_RATE_HZ

        def step() -> float:
            self.node.step_arm(dt)
            return dt

        self._loop(step)

    def _camera_loop(self) -> None:
        self._loop(self.node.publish_cloud)

    # -- inputs ------------------------------------------------------------------------------------
    def set_cloud(self, cloud: PointCloud2 | None, rate_hz: float | None = None) -> None:
        """What the camera publishes from now on (None: nothing), and at which rate [Hz]."""
        self.node.set_cloud(cloud, rate_hz)

    def set_joint_fault(self, fault: JointFault | None) -> None:
        """Publish fault(q) instead of the arm's joint state (None: the true state again)."""
        with self.node.lock:
            self.node.joint_fault = fault

    def set_goal(self, goal: PoseStamped | None) -> None:
        """The goal republished at 2 Hz (and published once now)."""
        with self.node.lock:
            self.node.goal = goal
        if goal is not None:
            self.node.pub_goal.publish(goal)

    def publish_goal_once(self, goal: PoseStamped) -> None:
        self.node.pub_goal.publish(goal)

    def ros_now(self) -> float:
        """The probe's ROS time [s] (wall clock; the nodes' clock when they run without the sim)."""
        return self.node.get_clock().now().nanoseconds * 1e-9

    def arm_q(self) -> np.ndarray:
        """The arm's latest measured (true) state (7,) [rad]."""
        with self.node.lock:
            if self.node.arm is not None:
                return self.node.arm.setpoint.copy()
            return self.node.measured[-1][1].copy() if self.node.measured else Q_READY.copy()

    # -- services ----------------------------------------------------------------------------------
    def call(self, client, request, timeout_s: float = 20.0):
        return super().call(client, request, timeout_s)

    def set_parameter(self, node: str, name: str, value, timeout_s: float = 30.0) -> tuple[bool, str]:
        """Set one parameter of `node`; returns (successful, reason)."""
        request = SetParameters.Request(parameters=[Parameter(name, value=value).to_parameter_msg()])
        result = self.call(self.node.param_clients[node], request, timeout_s).results[0]
        return bool(result.successful), result.reason

    def enable_planner(self, enabled: bool) -> None:
        self.call(self.node.enable_client, SetBool.Request(data=enabled))

    def reset_sim(self) -> str:
        """sim/reset; the arm jumps back to its start, which the safety monitor is told about."""
        with self.node.lock:
            self.node.safety.note_jump(time.monotonic())
        response = self.call(self.node.reset_client, Trigger.Request())
        if not response.success:
            raise RuntimeError(f"sim/reset failed: {response.message}")
        return response.message

    # -- what was seen -----------------------------------------------------------------------------
    def commands_since(self, t: float) -> list[tuple[float, np.ndarray | None, float]]:
        """(time received [s, monotonic], arm q (7,) or None if malformed, header stamp [s]) per command."""
        with self.node.lock:
            return [c for c in self.node.commands if c[0] >= t]

    def statuses_since(self, node: str, t: float) -> list[Status]:
        with self.node.lock:
            return [s for s in self.node.statuses.get(node, []) if s.t >= t]

    def logs_since(self, t: float) -> list[tuple[float, str, int, str]]:
        with self.node.lock:
            return [r for r in self.node.logs if r[0] >= t]

    def measured_since(self, t: float) -> list[tuple[float, np.ndarray]]:
        with self.node.lock:
            return [m for m in self.node.measured if m[0] >= t]

    def clouds_published_since(self, t: float) -> int:
        with self.node.lock:
            return sum(c >= t for c in self.node.clouds_published)

    def violation_count(self) -> int:
        with self.node.lock:
            return len(self.node.violations)

    def violations_since(self, t: float) -> list[Violation]:
        with self.node.lock:
            return [v for v in self.node.violations if v.time >= t]

    def safety_summary(self) -> dict:
        with self.node.lock:
            return self.node.safety.summary()

    def trim(self, keep_s: float = 60.0) -> None:
        """Forget records older than keep_s [s] (long runs)."""
        cut = time.monotonic() - keep_s
        with self.node.lock:
            n = self.node
            n.commands = [c for c in n.commands if c[0] >= cut]
            n.measured = [m for m in n.measured if m[0] >= cut]
            n.logs = [r for r in n.logs if r[0] >= cut]
            n.clouds_published = [c for c in n.clouds_published if c >= cut]
            n.statuses = {k: [s for s in v if s.t >= cut] for k, v in n.statuses.items()}

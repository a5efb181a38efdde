"""soak_probe: the node that drives and watches a soak run of the suite (``bench soak``).

It stands between the sim and the planner for two inputs, as relays the soak can interrupt: the sim's
``joint_states`` go on to ``soak/joint_states`` and its ``camera/points`` to ``soak/camera/points`` (the planner
and the scene encoder are remapped onto those), so a camera dropout or a joint-state hiccup is a pause of a relay
and needs no change to any node. It sends goals (``goal_pose``, republished at 2 Hz as a goal source does, or the
sim's ``target_pose`` relayed for a conveyor goal; ``grasp_pose``), one-shot ``planner/plan`` requests (answered in
the background) and parameter changes, resets the sim, and records into a ROS-free
:class:`~latent_planner_ros.evaluation.soak_report.SoakLog`: every ``joint_command`` checked by the
:class:`~latent_planner_ros.evaluation.safety.SafetyMonitor` against the sim's own ``joint_states`` (times:
``time.monotonic()``), the planner's status, ``sim/in_collision`` onsets and ``/rosout`` at WARN and above. Record
times are simulated time [s] from :meth:`SoakProbe.start`; :class:`SoakSession` runs the node on its own context.
"""

from __future__ import annotations

import math
import threading
import time

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from geometry_msgs.msg import PoseStamped
from nav_msgs.srv import GetPlan
from rcl_interfaces.msg import Log
from rcl_interfaces.srv import SetParameters
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import DurabilityPolicy, QoSProfile
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import JointState, PointCloud2
from std_msgs.msg import Bool
from std_srvs.srv import SetBool, Trigger

from latent_planner_ros.evaluation.probes.probe_session import ProbeSession
from latent_planner_ros.evaluation.safety import SafetyMonitor
from latent_planner_ros.evaluation.soak_report import GoalSent, SoakLog
from msg_adapters import AdapterError, joint_state_to_q, target_to_pose_stamped
from msg_adapters.plan_request import format_stamp

GOAL_RATE_HZ = 2.0
JOINTS_RELAY = "soak/joint_states"
CLOUD_RELAY = "soak/camera/points"
WATCHED_NODES = ("sim", "scene_encoder", "planner")


def _seconds(stamp) -> float:
    return stamp.sec + stamp.nanosec * 1e-9


class SoakProbe(Node):
    """See the module docstring."""

    def __init__(self, **kwargs):
        super().__init__("soak_probe", start_parameter_services=False, **kwargs)
        self.lock = threading.Lock()
        self.safety = SafetyMonitor()
        self.record = SoakLog(minutes=0.0)
        self.clock: float | None = None
        self.t0: float | None = None  # the soak's start [s, simulated]; None: not recording
        self.joints_on = True
        self.camera_on = True
        self.follow_target = False
        self.goal: tuple[object, PoseStamped] | None = None  # (publisher, message) republished at GOAL_RATE_HZ
        self._in_contact = False
        self._plan_results: dict[str, DiagnosticStatus] = {}  # request stamp -> the planner's plan_result
        self.relayed = {"joint_states": 0, "clouds": 0}

        self.pub_joints = self.create_publisher(JointState, JOINTS_RELAY, 10)
        self.pub_cloud = self.create_publisher(PointCloud2, CLOUD_RELAY, 2)
        self.pub_goal = self.create_publisher(PoseStamped, "goal_pose", 10)
        self.pub_grasp = self.create_publisher(PoseStamped, "grasp_pose", 10)
        self.create_subscription(Clock, "/clock", self._on_clock, 10)
        self.create_subscription(JointState, "joint_states", self._on_joint_states, 100)
        self.create_subscription(PointCloud2, "camera/points", self._on_cloud, 2, raw=True)
        self.create_subscription(PoseStamped, "target_pose", self._on_target, 10)
        self.create_subscription(Bool, "sim/in_collision", self._on_contact, 100)
        self.create_subscription(JointState, "joint_command", self._on_command, 50)
        self.create_subscription(DiagnosticArray, "planner/status", self._on_status, 50)
        self.create_subscription(DiagnosticStatus, "planner/plan_result", self._on_plan_result, 20)
        rosout_qos = QoSProfile(depth=200, durability=DurabilityPolicy.TRANSIENT_LOCAL)
        self.create_subscription(Log, "/rosout", self._on_log, rosout_qos)
        self.create_timer(1.0 / GOAL_RATE_HZ, self._republish_goal)
        self.param_clients = {n: self.create_client(SetParameters, f"{n}/set_parameters") for n in ("planner", "sim")}
        self.reset_client = self.create_client(Trigger, "sim/reset")
        self.enable_client = self.create_client(SetBool, "planner/enable")
        self.plan_client = self.create_client(GetPlan, "planner/plan")

    def _t(self) -> float | None:
        """The latest simulated time from the soak's start, or None while not recording (call under the lock)."""
        if self.t0 is None or self.clock is None:
            return None
        return self.clock - self.t0

    # -- relays and inputs -------------------------------------------------------------------------
    def _on_clock(self, msg: Clock) -> None:
        with self.lock:
            self.clock = _seconds(msg.clock)

    def _on_joint_states(self, msg: JointState) -> None:
        try:
            q, _ = joint_state_to_q(msg)
        except AdapterError:
            q = None
        with self.lock:
            if q is not None:
                self.safety.on_state(time.monotonic(), q)
            relay = self.joints_on
        if relay:
            self.pub_joints.publish(msg)
            self.relayed["joint_states"] += 1

    def _on_cloud(self, data: bytes) -> None:
        if self.camera_on:
            self.pub_cloud.publish(data)
            self.relayed["clouds"] += 1

    def _on_target(self, msg: PoseStamped) -> None:
        if self.follow_target:
            self.pub_goal.publish(msg)

    def _on_contact(self, msg: Bool) -> None:
        with self.lock:
            t = self._t()
            if t is not None and msg.data and not self._in_contact:
                self.record.contacts.append(t)
            self._in_contact = bool(msg.data)

    def _on_command(self, msg: JointState) -> None:
        with self.lock:
            found = self.safety.on_command(time.monotonic(), msg.name, msg.position)
            t = self._t()
            if t is None:
                return
            self.record.commands.append(_seconds(msg.header.stamp) - self.t0)
            self.record.violations += [(t, v.kind, v.detail) for v in found]

    def _on_status(self, msg: DiagnosticArray) -> None:
        for s in msg.status:
            values = {kv.key: kv.value for kv in s.values}
            try:
                tick_ms = float(values.get("tick_ms", "nan"))
            except ValueError:
                tick_ms = math.nan
            with self.lock:
                if self.t0 is None:
                    continue
                t = _seconds(msg.header.stamp) - self.t0
                state = values.get("state", s.message.split(":")[0])
                self.record.status.append((t, state, s.message, values.get("last_error", ""), tick_ms))
                self.record.doing.append(
                    (t, values.get("command_source", ""), values.get("p_collision", ""), s.message[:160])
                )

    def _on_plan_result(self, msg: DiagnosticStatus) -> None:
        values = {kv.key: kv.value for kv in msg.values}
        with self.lock:
            self._plan_results[values.get("request_stamp", "")] = msg

    def _on_log(self, msg: Log) -> None:
        if msg.name not in WATCHED_NODES or msg.level < Log.WARN:
            return
        with self.lock:
            t = self._t()
            if t is not None:
                self.record.logs.append((t, msg.name, int(msg.level), msg.msg))

    def _republish_goal(self) -> None:
        with self.lock:
            goal = self.goal
        if goal is not None:
            goal[0].publish(goal[1])


class SoakSession(ProbeSession):
    """A :class:`SoakProbe` on its own context and executor thread; service calls block (except plans).

    Args:
        domain_id: the ROS domain; None uses ``$ROS_DOMAIN_ID``.
    """

    def __init__(self, domain_id: int | None = None):
        super().__init__(lambda context: SoakProbe(context=context), "soak_probe", domain_id)

    # -- time and recording ---------------------------------------------------------------------------
    def clock(self) -> float | None:
        with self.node.lock:
            return self.node.clock

    def wait_clock(self, timeout_s: float = 30.0) -> float:
        end = time.monotonic() + timeout_s
        while (t := self.clock()) is None:
            if time.monotonic() > end:
                raise TimeoutError(f"no /clock within {timeout_s:g} s")
            time.sleep(0.05)
        return t

    def start(self, minutes: float) -> float:
        """Start recording now; returns the start [s, simulated]."""
        with self.node.lock:
            self.node.t0 = self.node.clock
            self.node.record.minutes = float(minutes)
            return self.node.t0

    def now(self) -> float:
        """Simulated time [s] since start()."""
        with self.node.lock:
            return self.node._t() or 0.0

    def with_record(self, fn):
        """fn(record) under the probe's lock (to add to or read the SoakLog)."""
        with self.node.lock:
            return fn(self.node.record)

    # -- inputs ---------------------------------------------------------------------------------------
    def set_relays(self, joints: bool | None = None, camera: bool | None = None) -> None:
        if joints is not None:
            self.node.joints_on = joints
        if camera is not None:
            self.node.camera_on = camera

    def send_goal(self, kind: str, pose: tuple | None, grasp: bool = False) -> None:
        """A new goal: `pose` = (position (3,) [m], quaternion (4,) xyzw) in world, republished at 2 Hz on
        goal_pose (grasp_pose with `grasp`); None = follow the sim's target_pose."""
        n = self.node
        msg = None
        if pose is not None:
            msg = target_to_pose_stamped(pose[0], pose[1], frame_id="world", stamp=n.get_clock().now().to_msg())
        with n.lock:
            n.follow_target = pose is None
            n.goal = None if msg is None else (n.pub_grasp if grasp else n.pub_goal, msg)
            t = n._t() or 0.0
            position = None if pose is None else tuple(round(float(v), 4) for v in pose[0])
            n.record.goals.append(GoalSent(t, kind, "grasp_pose" if grasp else "goal_pose", position))
        if msg is not None:
            (n.pub_grasp if grasp else n.pub_goal).publish(msg)

    def request_plan(self, pose: tuple, tolerance: float, expect: str) -> None:
        """A one-shot planner/plan in the background; its answer and plan_result are recorded when they come."""
        n = self.node
        request = GetPlan.Request(tolerance=float(tolerance))
        request.goal = target_to_pose_stamped(pose[0], pose[1], frame_id="world", stamp=n.get_clock().now().to_msg())
        key = format_stamp(request.goal.header.stamp)
        with n.lock:
            entry = {"t": round(n._t() or 0.0, 2), "tolerance": tolerance, "expect": expect, "answered": False}
            entry["_key"] = key
            n.record.plans.append(entry)
        if not n.plan_client.service_is_ready():
            with n.lock:
                entry["reason"] = "planner/plan not available"
            return
        sent = time.monotonic()
        future = n.plan_client.call_async(request)

        def done(f) -> None:
            response = f.result()
            with n.lock:
                entry.update(answered=response is not None, wall_s=round(time.monotonic() - sent, 2))
                if response is not None:
                    entry["waypoints"] = len(response.plan.poses)
                    entry["success"] = len(response.plan.poses) > 0

        future.add_done_callback(done)

    def settle_plans(self) -> None:
        """Attach each answered plan's plan_result message (its reason) and drop the matching keys."""
        with self.node.lock:
            for entry in self.node.record.plans:
                key = entry.get("_key")
                if key and key in self.node._plan_results:
                    entry["reason"] = self.node._plan_results.pop(key).message
                    entry.pop("_key")

    def set_parameter(self, node: str, name: str, value, timeout_s: float = 20.0) -> tuple[bool, str]:
        request = SetParameters.Request(parameters=[Parameter(name, value=value).to_parameter_msg()])
        result = self.call(self.node.param_clients[node], request, timeout_s).results[0]
        return bool(result.successful), result.reason

    def switch_scenario(self, scenario: str, seed: int, overrides: str) -> str:
        """Set the sim's scenario, seed and overrides and reset it; the arm's jump is announced to the monitor."""
        # the overrides are cleared first: the sim refuses a scenario that would not load with the overrides in
        # place (a tabletop with the conveyor's "{speed: ...}")
        steps = (
            ("scenario_overrides", ""),
            ("scenario", scenario),
            ("seed", int(seed)),
            ("scenario_overrides", overrides),
        )
        for name, value in steps:
            ok, reason = self.set_parameter("sim", name, value)
            if not ok:
                raise RuntimeError(f"sim refused {name}={value!r}: {reason}")
        with self.node.lock:
            self.node.safety.note_jump(time.monotonic())
        response = self.call(self.node.reset_client, Trigger.Request())
        with self.node.lock:
            self.node.safety.note_jump(time.monotonic())  # the jump happened during the call
        if not response.success:
            raise RuntimeError(f"sim/reset failed: {response.message}")
        return response.message

    def enable_planner(self, enabled: bool) -> None:
        response = self.call(self.node.enable_client, SetBool.Request(data=enabled))
        if not response.success:
            raise RuntimeError(f"planner/enable refused: {response.message}")

    def safety_summary(self) -> dict:
        with self.node.lock:
            return self.node.safety.summary()

"""reach_probe: asks a planner node for a plan (nav_msgs/GetPlan) and executes the plan in the sim.

Calls ``<planner>/plan`` and takes the plan's joint trajectory from ``<planner>/trajectory`` (the message with
the returned Path's stamp); for a failed plan, the reason is the ``last_error`` of ``<planner>/status``.
Execution streams ``joint_command`` along the trajectory with a
:class:`~latent_planner_ros.planning.trajectory_stream.TrajectoryStreamer`, one target per `period_s` of
simulated time (driven by the ``joint_states`` stamps), and records ``joint_states``, ``sim/min_distance`` and
``sim/in_collision`` meanwhile. :class:`ReachSession` runs the node in its own rclpy context on a background
thread (no signal handlers); its calls block:

    with ReachSession(domain_id, planners=("planner", "ompl_planner")) as probe:
        call = probe.plan("planner", position, quaternion_xyzw, tolerance=0.01)
        log, finished = probe.execute(call.q_path, call.times)   # a ROS-free ExecutionLog
"""

from __future__ import annotations

import threading
import time
from collections.abc import Sequence

import numpy as np
from diagnostic_msgs.msg import DiagnosticArray
from nav_msgs.srv import GetPlan
from rclpy.node import Node
from sensor_msgs.msg import JointState
from std_msgs.msg import Bool, Float64
from trajectory_msgs.msg import JointTrajectory

from latent_planner_ros.evaluation.probes.probe_session import ProbeSession
from latent_planner_ros.evaluation.reach import ExecutionLog, PlanCall
from latent_planner_ros.planning.trajectory_stream import TrajectoryStreamer
from msg_adapters import (
    AdapterError,
    joint_state_to_q,
    path_to_arrays,
    q_to_joint_state,
    target_to_pose_stamped,
    trajectory_to_arrays,
)


def _seconds(stamp) -> float:
    return stamp.sec + stamp.nanosec * 1e-9


class ReachProbe(Node):
    """Clients of the planners' plan services, their trajectories, the sim's state, and joint_command."""

    def __init__(self, planners: Sequence[str], **kwargs):
        super().__init__("reach_probe", start_parameter_services=False, **kwargs)
        self._lock = threading.Lock()
        self.q: np.ndarray | None = None
        self.stamp = -np.inf
        self.trajectories: dict[str, dict[tuple[int, int], JointTrajectory]] = {p: {} for p in planners}
        self.last_error: dict[str, tuple[float, str]] = {}  # planner -> (receipt time [s, monotonic], text)
        self.plan_clients = {p: self.create_client(GetPlan, f"{p}/plan") for p in planners}
        for p in planners:
            self.create_subscription(JointTrajectory, f"{p}/trajectory", lambda m, p=p: self._on_traj(p, m), 10)
            self.create_subscription(DiagnosticArray, f"{p}/status", lambda m, p=p: self._on_status(p, m), 10)
        self.create_subscription(JointState, "joint_states", self._on_joints, 100)
        self.create_subscription(Float64, "sim/min_distance", self._on_distance, 100)
        self.create_subscription(Bool, "sim/in_collision", self._on_contact, 100)
        self.pub_command = self.create_publisher(JointState, "joint_command", 10)
        self._streamer: TrajectoryStreamer | None = None
        self._last_command = -np.inf
        self._rows: dict[str, list] | None = None

    def _on_traj(self, planner: str, msg: JointTrajectory) -> None:
        with self._lock:
            self.trajectories[planner][(msg.header.stamp.sec, msg.header.stamp.nanosec)] = msg

    def _on_status(self, planner: str, msg: DiagnosticArray) -> None:
        for status in msg.status:
            text = next((kv.value for kv in status.values if kv.key == "last_error"), "")
            with self._lock:
                self.last_error[planner] = (time.monotonic(), text)

    def _on_joints(self, msg: JointState) -> None:
        try:
            q, _ = joint_state_to_q(msg)
        except AdapterError:
            return
        t = _seconds(msg.header.stamp)
        with self._lock:
            self.q, self.stamp = q, t
            if self._rows is not None:
                self._rows["joints"].append((t, q))
            streamer = self._streamer
            due = streamer is not None and t - self._last_command >= streamer.period - 1e-6
            if due:
                self._last_command = t
        if due:
            command = streamer.next_command(q)
            if command is not None:
                self.pub_command.publish(q_to_joint_state(command, stamp=msg.header.stamp))

    # sim/min_distance and sim/in_collision carry no stamp: the sim publishes them right after joint_states.
    def _on_distance(self, msg: Float64) -> None:
        with self._lock:
            if self._rows is not None:
                self._rows["distance"].append((self.stamp, float(msg.data)))

    def _on_contact(self, msg: Bool) -> None:
        with self._lock:
            if self._rows is not None:
                self._rows["contact"].append((self.stamp, bool(msg.data)))

    def status_error(self, planner: str) -> tuple[float, str]:
        """(receipt time [s, monotonic], last_error) of the planner's latest status; (-inf, "") before any."""
        with self._lock:
            return self.last_error.get(planner, (-np.inf, ""))

    def latest_q(self) -> np.ndarray | None:
        """The last measured configuration (7,) [rad], or None before the first joint state."""
        with self._lock:
            return None if self.q is None else self.q.copy()

    def start_execution(self, streamer: TrajectoryStreamer) -> None:
        with self._lock:
            self._rows = {"joints": [], "distance": [], "contact": []}
            self._last_command = -np.inf
            self._streamer = streamer

    def stop_execution(self) -> dict[str, list]:
        with self._lock:
            rows, self._rows, self._streamer = self._rows, None, None
        return rows or {"joints": [], "distance": [], "contact": []}


class ReachSession(ProbeSession):
    """A :class:`ReachProbe` spun on a background thread in its own context.

    Args:
        domain_id: the ROS domain; None uses ``$ROS_DOMAIN_ID``.
        planners: names of the planner nodes (their ``<name>/plan`` services).
    """

    def __init__(self, domain_id: int | None = None, planners: Sequence[str] = ("planner", "ompl_planner")):
        super().__init__(lambda context: ReachProbe(planners, context=context), "reach_probe", domain_id)

    def plan(
        self, planner: str, position: np.ndarray, quaternion_xyzw: np.ndarray, tolerance: float, timeout_s: float = 90.0
    ) -> PlanCall:
        """One GetPlan call on `planner` and its trajectory; plan_s is the call's wall-clock time [s]."""
        client = self.node.plan_clients[planner]
        if not client.wait_for_service(timeout_sec=30.0):
            raise TimeoutError(f"service {planner}/plan is not available")
        request = GetPlan.Request(goal=target_to_pose_stamped(position, quaternion_xyzw), tolerance=float(tolerance))
        done = threading.Event()
        t0 = time.monotonic()
        future = client.call_async(request)
        future.add_done_callback(lambda _: done.set())
        if not done.wait(timeout_s) or future.result() is None:
            raise TimeoutError(f"no answer from {planner}/plan within {timeout_s:g} s")
        plan_s = time.monotonic() - t0
        path = future.result().plan
        ee_path, _ = path_to_arrays(path)
        if not len(ee_path):
            reason = self._status_after(planner, time.monotonic())
            return PlanCall(planner, False, plan_s, ee_path, np.zeros((0, 7)), np.zeros(0), reason)
        stamp = (path.header.stamp.sec, path.header.stamp.nanosec)
        end = time.monotonic() + 10.0
        while (traj := self.node.trajectories[planner].get(stamp)) is None:
            if time.monotonic() > end:
                raise TimeoutError(f"{planner}/trajectory with the plan's stamp did not arrive")
            time.sleep(0.02)
        q_path, times = trajectory_to_arrays(traj)
        return PlanCall(planner, True, plan_s, ee_path, q_path, times)

    def _status_after(self, planner: str, since: float, timeout_s: float = 3.0) -> str:
        """The `last_error` of the first `<planner>/status` received after `since` (monotonic [s]), or ""."""
        end = time.monotonic() + timeout_s
        while time.monotonic() < end:
            received, text = self.node.status_error(planner)
            if received > since:
                return text
            time.sleep(0.05)
        return ""

    def execute(self, q_path: np.ndarray, times: np.ndarray, period_s: float = 0.1, timeout_s: float = 60.0):
        """Stream joint_command along (q_path (T, 7) [rad], times (T,) [s]) until the streamer finishes.

        Returns:
            ExecutionLog of the execution (times relative to its start, simulated time), and whether the
            streamer finished within `timeout_s` of wall-clock time.
        """
        streamer = TrajectoryStreamer(q_path, times, period=period_s)
        self.node.start_execution(streamer)
        end = time.monotonic() + timeout_s
        while not streamer.done and time.monotonic() < end:
            time.sleep(0.05)
        rows = self.node.stop_execution()
        return ExecutionLog.from_rows(rows), streamer.done

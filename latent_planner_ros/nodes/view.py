"""view node: the live 3D view of the suite in the browser (view/scene.py on a viser server).

Subscribes joint_states (the arm), joint_command (the commanded state, translucent), every PointCloud2 topic named
``.../points`` (discovered every second; the fused clouds the nodes work from), target_pose, goal_pose,
``<planner>/status`` (state, tick time, errors; the arm coloured by its p_collision), ``<planner>/markers`` and
``obstacles`` (paths, goal, cylinders), ``<planner>/trajectory`` and joint_trajectory (their TCP paths).
Inputs are kept newest-only and drawn by a timer at ``--rate`` (15 Hz) while a page is open (nothing is drawn
without one), so fast topics cost one conversion per frame; the process runs at a lower CPU priority (``--nice``).
Controls: the goal gizmo and the goal fields publish goal_pose (frame world; at most 10 Hz while dragging), the
"Planner enabled" box calls ``<planner>/enable``, "Pause" freezes the view.

    python -m latent_planner_ros view [--port 8080] [--host 127.0.0.1] [--planner planner] [--rate 15] [--nice 10]
"""

from __future__ import annotations

import argparse
import os
import sys
import time

import numpy as np
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import PoseStamped
from rclpy.node import Node
from sensor_msgs.msg import JointState, PointCloud2
from std_srvs.srv import SetBool
from trajectory_msgs.msg import JointTrajectory
from visualization_msgs.msg import Marker, MarkerArray

from latent_planner_ros.nodes.node_main import run_node
from latent_planner_ros.view.process import DEFAULT_PORT
from latent_planner_ros.view.scene import Shape, SuiteScene
from msg_adapters import AdapterError, cloud_to_xyz, joint_state_to_q

GOAL_PERIOD_S = 0.1
"""[s] shortest interval between two goals sent while the gizmo is dragged."""
CLOUD_TYPE = "sensor_msgs/msg/PointCloud2"


def _wxyz(q) -> np.ndarray:
    return np.array([q.w, q.x, q.y, q.z], dtype=float)


def _xyz(p) -> np.ndarray:
    return np.array([p.x, p.y, p.z], dtype=float)


def marker_shape(m: Marker) -> Shape | None:
    """The drawable shape of a CYLINDER, SPHERE or LINE_STRIP marker (others: None)."""
    rgb = tuple(int(255 * c) for c in (m.color.r, m.color.g, m.color.b))
    pose, scale = m.pose, np.array([m.scale.x, m.scale.y, m.scale.z])
    kinds = {Marker.CYLINDER: "cylinder", Marker.SPHERE: "sphere", Marker.LINE_STRIP: "line"}
    if m.type not in kinds:
        return None
    points = np.array([[p.x, p.y, p.z] for p in m.points]) if m.type == Marker.LINE_STRIP else None
    return Shape(kinds[m.type], _xyz(pose.position), _wxyz(pose.orientation), scale, rgb, points)


class ViewNode(Node):
    """The view (see the module docstring).

    Args:
        port: HTTP port on `host` (the next free one if taken; see :attr:`url`).
        planner: the planner node's name (its status, markers, trajectory and enable service).
        rate_hz: [Hz] drawing rate.
    """

    def __init__(
        self, port: int = DEFAULT_PORT, host: str = "127.0.0.1", planner: str = "planner", rate_hz: float = 15.0, **kw
    ):
        super().__init__("view", **kw)
        import viser

        self.server = viser.ViserServer(host=host, port=port, verbose=False)
        self.url = f"http://{'localhost' if host in ('127.0.0.1', '0.0.0.0') else host}:{self.server.get_port()}"
        self.scene = SuiteScene(self.server, on_goal=self._goal_moved, on_enable=self._enable)
        self.pub_goal = self.create_publisher(PoseStamped, "goal_pose", 10)
        self.enable_client = self.create_client(SetBool, f"{planner}/enable")
        self._newest: dict[str, object] = {}
        self._clouds: dict[str, PointCloud2] = {}
        self._shapes: dict[str, Shape] = {}
        self._shapes_changed = False
        self._goal_pending: tuple[np.ndarray, np.ndarray] | None = None
        self._goal_sent_at = 0.0
        self._placed = False
        self.frames_drawn = 0
        self.clouds_drawn = 0
        self._rates_at, self._rates_base = time.monotonic(), (0, 0)
        self.create_subscription(JointState, "joint_states", lambda m: self._keep("joints", m), 10)
        self.create_subscription(JointState, "joint_command", lambda m: self._keep("command", m), 10)
        self.create_subscription(PoseStamped, "target_pose", lambda m: self._keep("target", m), 10)
        self.create_subscription(PoseStamped, "goal_pose", lambda m: self._keep("goal", m), 10)
        self.create_subscription(DiagnosticArray, f"{planner}/status", lambda m: self._keep("status", m), 10)
        self.create_subscription(JointTrajectory, f"{planner}/trajectory", lambda m: self._keep("plan", m), 10)
        self.create_subscription(JointTrajectory, "joint_trajectory", lambda m: self._keep("segment", m), 10)
        self.create_subscription(MarkerArray, f"{planner}/markers", lambda m: self._on_markers("planner", m), 10)
        self.create_subscription(MarkerArray, "obstacles", lambda m: self._on_markers("obstacles", m), 10)
        self._cloud_subs: dict[str, object] = {}
        self.create_timer(1.0, self._discover_clouds)
        self.create_timer(1.0 / rate_hz, self._draw)
        self._discover_clouds()
        self.get_logger().info(f"the view: {self.url}")

    # -- inputs (executor thread) -------------------------------------------------------------------
    def _keep(self, key: str, msg) -> None:
        self._newest[key] = msg

    def _discover_clouds(self) -> None:
        for topic, types in self.get_topic_names_and_types():
            if topic.endswith("points") and CLOUD_TYPE in types and topic not in self._cloud_subs:
                self._cloud_subs[topic] = self.create_subscription(
                    PointCloud2, topic, lambda m, t=topic: self._clouds.__setitem__(t, m), 2
                )

    def _on_markers(self, source: str, msg: MarkerArray) -> None:
        for m in msg.markers:
            key = f"{source}_{m.ns}_{m.id}"
            if m.action == Marker.DELETEALL:
                self._shapes = {k: v for k, v in self._shapes.items() if not k.startswith(f"{source}_")}
            elif m.action == Marker.DELETE:
                self._shapes.pop(key, None)
            else:
                shape = marker_shape(m)
                if shape is not None:
                    self._shapes[key] = shape
        self._shapes_changed = True

    # -- drawing (timer) ---------------------------------------------------------------------------
    def _draw(self) -> None:
        self._send_pending_goal()
        if not self.server.get_clients():  # nobody is looking: keep the newest inputs, draw nothing
            return
        newest, self._newest = self._newest, {}
        clouds, self._clouds = self._clouds, {}
        scene = self.scene
        try:
            if "joints" in newest:
                q, _ = joint_state_to_q(newest["joints"])
                scene.set_joint_state(q)
                if not self._placed:  # the gizmo starts at the TCP
                    self._placed = True
                    wxyz, pos = scene.meshes.tcp(q)
                    scene.place_goal(pos, wxyz)
            if "command" in newest:
                scene.set_command(joint_state_to_q(newest["command"])[0])
        except AdapterError as err:
            self.get_logger().warning(f"joint state not shown: {err}", throttle_duration_sec=5.0)
        for topic, msg in clouds.items():
            try:
                scene.set_cloud(topic.lstrip("/"), cloud_to_xyz(msg))
                self.clouds_drawn += 1
            except AdapterError as err:
                self.get_logger().warning(f"{topic} not shown: {err}", throttle_duration_sec=5.0)
        for key in ("target", "goal"):
            if key in newest:
                pose = newest[key].pose
                setter = scene.set_target if key == "target" else scene.set_goal_received
                setter(_xyz(pose.position), _wxyz(pose.orientation))
        for key in ("plan", "segment"):
            if key in newest and newest[key].points:
                q = np.array([p.positions for p in newest[key].points], dtype=float)
                if q.shape[1] == 7:
                    scene.set_path(key, _tcp_path(q))
        if "status" in newest and newest["status"].status:
            status = newest["status"].status[0]
            scene.set_status({kv.key: kv.value for kv in status.values}, int.from_bytes(status.level, "little"))
        if self._shapes_changed:
            self._shapes_changed = False
            scene.set_shapes(dict(self._shapes))
        self.frames_drawn += 1
        now = time.monotonic()
        if now - self._rates_at >= 2.0:
            frames, clouds = self.frames_drawn - self._rates_base[0], self.clouds_drawn - self._rates_base[1]
            span, self._rates_at, self._rates_base = now - self._rates_at, now, (self.frames_drawn, self.clouds_drawn)
            scene.set_info(f"{frames / span:.1f} frames/s, {clouds / span:.1f} clouds/s sent to the page")

    # -- controls (viser threads) ------------------------------------------------------------------
    def _goal_moved(self, position: np.ndarray, wxyz: np.ndarray) -> None:
        self._goal_pending = (position, wxyz)
        self._send_pending_goal()

    def _send_pending_goal(self) -> None:
        pending = self._goal_pending
        if pending is None or time.monotonic() - self._goal_sent_at < GOAL_PERIOD_S:
            return
        self._goal_pending, self._goal_sent_at = None, time.monotonic()
        position, wxyz = pending
        msg = PoseStamped()
        msg.header.frame_id = "world"
        msg.header.stamp = self.get_clock().now().to_msg()
        msg.pose.position.x, msg.pose.position.y, msg.pose.position.z = (float(v) for v in position)
        o = msg.pose.orientation
        o.w, o.x, o.y, o.z = (float(v) for v in wxyz)
        self.pub_goal.publish(msg)

    def _enable(self, on: bool) -> None:
        if not self.enable_client.service_is_ready():
            self.get_logger().warning(f"{self.enable_client.srv_name} is not available")
            return
        self.enable_client.call_async(SetBool.Request(data=bool(on)))

    def destroy_node(self) -> None:
        self.server.stop()
        super().destroy_node()


def _tcp_path(q: np.ndarray) -> np.ndarray:
    """TCP positions (T, 3) [m] of joint paths q (T, 7) [rad]."""
    from latent_planner_ros.robot.panda import load_panda

    return load_panda().fk_batch(q)[0]


def parse_args(argv: list[str]) -> argparse.Namespace:
    p = argparse.ArgumentParser(prog="latent-planner view", description=__doc__.split("\n\n")[0])
    p.add_argument("--port", type=int, default=DEFAULT_PORT, help=f"HTTP port (default {DEFAULT_PORT})")
    p.add_argument("--host", default="127.0.0.1", help="address to serve on (default 127.0.0.1: this machine only)")
    p.add_argument("--planner", default="planner", help="the planner node's name (default planner)")
    p.add_argument("--rate", type=float, default=15.0, metavar="HZ", help="drawing rate (default 15 Hz)")
    p.add_argument(
        "--nice", type=int, default=10, metavar="N", help="lower the process's CPU priority by N (default 10; 0 = not)"
    )
    args = p.parse_args(argv)
    if not 1.0 <= args.rate <= 60.0:
        p.error("--rate must be in [1, 60] Hz")
    return args


def main(argv: list[str] | None = None) -> int:
    """Entry point: `argv` = arguments after ``view`` (ROS arguments after ``--ros-args`` are passed on)."""
    argv = sys.argv[1:] if argv is None else list(argv)
    cut = argv.index("--ros-args") if "--ros-args" in argv else len(argv)
    args = parse_args(argv[:cut])
    sys.argv = ["view", *argv[cut:]]
    if args.nice:
        os.nice(args.nice)  # the control loop's nodes come first on a machine with few cores
    return run_node("view", lambda: ViewNode(args.port, args.host, args.planner, args.rate), (OSError,))

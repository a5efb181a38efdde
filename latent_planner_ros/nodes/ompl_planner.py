"""ompl_planner node: the OMPL baseline behind the planner node's GetPlan contract, with optional execution.

Subscribes joint_states and each topic of `cloud_topics` (default camera/points): the topics' newest clouds are
fused in `frame_id` at each plan (perception/cloud_fusion.py: one stamped more than `cloud_max_age_s` from the
newest is left out and named on status; a cloud in another frame is refused with the topic and reason).
Service ~/plan (nav_msgs/GetPlan): `goal` = TCP target pose,
`start` ignored (the current joint state is the start), `tolerance` = position tolerance [m] (0: the
configured one; NaN, inf or negative: refused); the response is the end-effector path, empty on failure.
Publishes ~/trajectory (the joint trajectory, same header stamp as the returned Path), ~/markers, ~/status (state,
reason of the last failure, timings), ~/plan_result (diagnostic_msgs/DiagnosticStatus: the outcome of every
~/plan request, OK on success, ERROR on a failure or refusal) and, with `execute`, joint_command at
`command_rate_hz` along the trajectory.
Parameters: OmplPlannerNodeConfig (config/ompl_planner.yaml), validated; a bad value is refused with a reason.

    python -m latent_planner_ros run ompl_planner [--ros-args --params-file config/ompl_planner.yaml]
"""

from __future__ import annotations

import math
import sys
from functools import partial

import numpy as np
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from nav_msgs.msg import Path
from nav_msgs.srv import GetPlan
from rcl_interfaces.msg import ParameterDescriptor, SetParametersResult
from rclpy.node import Node
from sensor_msgs.msg import JointState, PointCloud2
from trajectory_msgs.msg import JointTrajectory
from visualization_msgs.msg import MarkerArray

from latent_planner_ros.nodes.markers import path_markers
from latent_planner_ros.nodes.node_main import run_node
from latent_planner_ros.nodes.ompl_planner_config import OmplPlannerNodeConfig
from latent_planner_ros.perception.cloud_fusion import CloudFusion, CloudRefused
from latent_planner_ros.planning.goal import Goal
from latent_planner_ros.planning.ompl_baseline import OmplPlanner
from latent_planner_ros.planning.trajectory_stream import TrajectoryStreamer
from msg_adapters import (
    AdapterError,
    cloud_to_xyz,
    ee_path_to_path,
    joint_path_to_trajectory,
    joint_state_to_q,
    plan_result_status,
    plan_tolerance,
    pose_stamped_to_target,
    q_to_joint_state,
    status_array,
)
from msg_adapters.plan_request import FAILED, REFUSED, SUCCESS
from sim_bridge.params import ConfigError, from_params, to_params

OK, WARN = 0, 1
"""Diagnostic levels (as in diagnostic_msgs/DiagnosticStatus)."""


class OmplPlannerNode(Node):
    def __init__(self):
        super().__init__("ompl_planner")
        names = to_params(OmplPlannerNodeConfig())
        for name, value in names.items():
            self.declare_parameter(name, value, ParameterDescriptor(dynamic_typing=True))
        self.config = from_params(OmplPlannerNodeConfig, {n: self.get_parameter(n).value for n in names})
        self.planner = OmplPlanner(self.config.ompl)
        self.add_on_set_parameters_callback(self._on_set_parameters)
        self._q: np.ndarray | None = None
        self._q_time = -math.inf
        self.fusion = CloudFusion(self.config.cloud_topics, self.config.frame_id, self.config.cloud_max_age_s)
        self._streamer: TrajectoryStreamer | None = None
        self._state, self._last_error = "idle", ""
        self._last: dict[str, object] = {}

        self.pub_command = self.create_publisher(JointState, "joint_command", 10)
        self.pub_traj = self.create_publisher(JointTrajectory, "~/trajectory", 10)
        self.pub_markers = self.create_publisher(MarkerArray, "~/markers", 10)
        self.pub_status = self.create_publisher(DiagnosticArray, "~/status", 10)
        self.pub_plan_result = self.create_publisher(DiagnosticStatus, "~/plan_result", 10)
        self.create_subscription(JointState, "joint_states", self._on_joint_states, 10)
        for cloud_topic in self.config.cloud_topics:
            self.create_subscription(PointCloud2, cloud_topic, partial(self._on_cloud, cloud_topic), 2)
        self.create_service(GetPlan, "~/plan", self._on_plan)
        self.create_timer(1.0 / self.config.command_rate_hz, self._on_tick)
        self.create_timer(1.0 / self.config.status_rate_hz, self._publish_status)
        self.get_logger().info(
            f"OMPL baseline ready: {self.planner.config.planner}, octree {self.config.ompl.octree_resolution} m, "
            f"execute={self.config.execute}"
        )

    def _now(self) -> float:
        return self.get_clock().now().nanoseconds * 1e-9

    def _error(self, text: str) -> None:
        self._last_error = text
        self.get_logger().warning(text, throttle_duration_sec=1.0)

    # -- parameters ------------------------------------------------------------------------------
    def _on_set_parameters(self, params) -> SetParametersResult:
        try:
            config = from_params(OmplPlannerNodeConfig, {p.name: p.value for p in params}, base=self.config)
            if tuple(config.cloud_topics) != tuple(self.config.cloud_topics) or config.frame_id != self.fusion.frame_id:
                raise ConfigError("cloud_topics, frame_id: the subscriptions are fixed at start-up (restart the node)")
            planner = OmplPlanner(config.ompl)
        except (ConfigError, ValueError, TypeError) as err:
            return SetParametersResult(successful=False, reason=str(err))
        self.config, self.planner = config, planner
        self.fusion.max_age_s = config.cloud_max_age_s
        return SetParametersResult(successful=True)

    # -- inputs -------------------------------------------------------------------------------------
    def _on_joint_states(self, msg: JointState) -> None:
        try:
            self._q, _ = joint_state_to_q(msg)
        except AdapterError as err:
            self._error(f"joint_states refused: {err}")
            return
        self._q_time = self._now()

    def _on_cloud(self, cloud_topic: str, msg: PointCloud2) -> None:
        frame = msg.header.frame_id or self.config.frame_id  # an empty frame is taken as frame_id
        try:
            self.fusion.check(cloud_topic, frame)
            stamp = msg.header.stamp.sec + msg.header.stamp.nanosec * 1e-9
            self.fusion.add_cloud(cloud_topic, cloud_to_xyz(msg), frame, stamp, int(msg.width) * int(msg.height))
        except CloudRefused as err:
            self._error(str(err))
        except AdapterError as err:
            self._error(f"{cloud_topic} refused: {err}")

    def _fresh_q(self) -> np.ndarray | None:
        if self._q is None or self._now() - self._q_time > self.config.stale_joint_states_s:
            return None
        return self._q.copy()

    # -- planning -----------------------------------------------------------------------------------
    def _on_plan(self, request: GetPlan.Request, response: GetPlan.Response) -> GetPlan.Response:
        """Plan once; every request, refused or planned, is answered on ~/plan_result as well."""
        response.plan = Path()
        response.plan.header.frame_id = self.config.frame_id
        response.plan.header.stamp = self.get_clock().now().to_msg()
        outcome, reason, result = self._plan(request, response)
        if outcome == REFUSED:
            self._fail(f"plan refused: {reason}")
        elif outcome == FAILED:
            self._fail(f"plan failed: {reason}")
        else:
            self._last_error = ""  # a successful plan clears the error of an earlier one
        timing = (result.planning_time_s, result.final_pos_err_m) if result is not None else (None, None)
        stamp, waypoints = request.goal.header.stamp, len(response.plan.poses)
        self.pub_plan_result.publish(plan_result_status(self.get_name(), outcome, reason, stamp, waypoints, *timing))
        return response

    def _plan(self, request: GetPlan.Request, response: GetPlan.Response) -> tuple[str, str, object]:
        """(outcome, reason, PlanResult or None): SUCCESS fills `response`, publishes and starts the execution."""
        q = self._fresh_q()
        if q is None:
            return REFUSED, "no fresh joint states", None
        try:
            target = pose_stamped_to_target(request.goal, expected_frame=self.config.frame_id)
            pos_tol = plan_tolerance(request.tolerance, self.config.pos_tol)
            ori_tol = math.radians(self.config.ori_tol_deg)
            goal = Goal(target.position, target.rotation, pos_tol=pos_tol, ori_tol=ori_tol)
        except (AdapterError, ValueError) as err:
            return REFUSED, str(err), None
        fused = self.fusion.fuse()
        if not fused.sources and self.config.require_cloud:
            return REFUSED, "no point cloud received yet", None
        if fused.stale:
            self._error(f"clouds left out as stale: {fused.describe()}")
        self._streamer = None  # a valid new request stops the execution of the previous plan
        self._state = "planning"
        result = self.planner.plan(q, goal, fused.points if fused.sources else None)
        self._last = {
            "last_success": result.success,
            "last_reason": result.reason,
            "planning_time_s": result.planning_time_s,
            **{k: v for k, v in result.timings.items() if k != "total_s"},
            "states_checked": result.iterations,
            "cloud_points": result.info.get("cloud_points", 0),
            "cloud_sources": fused.describe(),
            "goal_states": result.info.get("goal_states", 0),
            "path_states": len(result.q_path),
        }
        self.get_logger().info(
            f"plan: {'success' if result.success else 'failure'} ({result.reason}) in {result.planning_time_s:.3f} s, "
            f"{len(result.q_path)} states, error {result.final_pos_err_m * 1000:.1f} mm"
        )
        if not result.success:
            return FAILED, result.reason, result
        stamp = response.plan.header.stamp
        frame = self.config.frame_id
        response.plan = ee_path_to_path(result.ee_positions, result.ee_quaternions, frame_id=frame, stamp=stamp)
        self.pub_traj.publish(joint_path_to_trajectory(result.q_path, result.times, stamp=stamp))
        self.pub_markers.publish(path_markers(result.ee_positions, goal.position, stamp, frame_id=frame))
        self._state = "planned"
        if self.config.execute:
            self._streamer = TrajectoryStreamer(result.q_path, result.times, period=1.0 / self.config.command_rate_hz)
            self._state = "executing"
        return SUCCESS, result.reason, result

    def _fail(self, reason: str) -> None:
        self._state = "failed"
        self._error(reason)

    # -- execution ----------------------------------------------------------------------------------
    def _on_tick(self) -> None:
        if self._streamer is None:
            return
        q = self._fresh_q()
        if q is None:
            self._error("execution paused: no fresh joint states")
            return
        command = self._streamer.next_command(q)
        if command is None:
            self._streamer = None
            self._state = "executed"
            return
        self.pub_command.publish(q_to_joint_state(command, stamp=self.get_clock().now().to_msg()))

    def _publish_status(self) -> None:
        level = WARN if self._state == "failed" else OK
        message = f"{self._state}: {self._last_error}" if self._state == "failed" else self._state
        values = {
            "state": self._state,
            "executing": self._streamer is not None,
            "planner": self.planner.name,
            "last_error": self._last_error,
            **self._last,
        }
        stamp = self.get_clock().now().to_msg()
        msg = status_array("ompl_planner", level, message, values, self.planner.name, stamp)
        self.pub_status.publish(msg)


def main() -> int:
    return run_node("ompl_planner", OmplPlannerNode, (ConfigError, ValueError))


if __name__ == "__main__":
    sys.exit(main())

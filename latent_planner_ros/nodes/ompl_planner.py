"""ompl_planner node: the OMPL baseline behind the planner node's GetPlan contract, with optional execution.

Subscribes joint_states (`<frames.joint_prefix>joint1..7`) and each topic of `cloud_topics` (default camera/points):
the topics' newest clouds are fused in the robot base frame at each plan (perception/cloud_fusion.py: one stamped
more than `cloud_max_age_s` from the newest is left out and named on status; clouds in `world`, the base frame or a
frame of `frames.extrinsics` are transformed, any other frame is refused with the topic and reason).
Service ~/plan (nav_msgs/GetPlan): `goal` = TCP target pose (in `world`, the base frame or an extrinsic frame),
`start` ignored (the current joint state is the start), `tolerance` = position tolerance [m] (0: the
configured one; NaN, inf or negative: refused); the response is the end-effector path, empty on failure.
Publishes ~/trajectory (the plan's jerk-limited trajectory within `limits`, with velocities and accelerations, at
rest at both ends; same header stamp as the returned Path; paths and markers in `world`), ~/markers, ~/status and
/diagnostics (state, reason of the last failure, timings), ~/plan_result (diagnostic_msgs/DiagnosticStatus: the
outcome of every ~/plan request, OK on success, ERROR on a failure or refusal) and, with `execute`, that
trajectory once on joint_trajectory (stamp 0 = on receipt: a JointTrajectoryController or the sim executes it).
Turning `execute` on claims the arm on execution_owner; a newer claim of another node (the planner enabled) turns
it off (nodes/execution_owner.py), so two planners never command at once.
Parameters: OmplPlannerNodeConfig (config/ompl_planner.yaml), statically typed with descriptors
(latent_planner_ros/params/ros.py); a bad value is refused with its dotted name and the reason; `status_rate_hz` changes
re-create its timer; `cloud_topics` and `frames.*` are read-only.

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
from rcl_interfaces.msg import SetParametersResult
from rclpy.node import Node
from rclpy.parameter import Parameter
from sensor_msgs.msg import JointState, PointCloud2
from std_msgs.msg import Header
from trajectory_msgs.msg import JointTrajectory
from visualization_msgs.msg import Marker, MarkerArray

from latent_planner_ros.nodes.execution_owner import QOS as OWNER_QOS
from latent_planner_ros.nodes.execution_owner import ExecutionOwner
from latent_planner_ros.nodes.grasp_target_input import GraspTargetInput
from latent_planner_ros.nodes.markers import path_markers
from latent_planner_ros.nodes.node_main import run_node
from latent_planner_ros.nodes.ompl_planner_config import RANGES, READ_ONLY, OmplPlannerNodeConfig
from latent_planner_ros.nodes.qos import CloudSubscription
from latent_planner_ros.params.config import ConfigError, from_params
from latent_planner_ros.params.ros import ConfigParams
from latent_planner_ros.perception.cloud_fusion import CloudFusion, CloudRefused
from latent_planner_ros.perception.frames import WORLD, path_to_world
from latent_planner_ros.planning.goal import Goal
from latent_planner_ros.planning.grasp import grasp_reason, plan_grasp_spec
from latent_planner_ros.planning.ompl_baseline import OmplPlanner
from latent_planner_ros.planning.time_parameterisation import jerk_limited_trajectory
from msg_adapters import (
    AdapterError,
    cloud_to_xyz,
    ee_path_to_path,
    joint_path_to_trajectory,
    joint_state_to_q,
    plan_result_status,
    plan_tolerance,
    status_array,
)
from msg_adapters.plan_request import FAILED, REFUSED, SUCCESS
from msg_adapters.pose import pose_stamped_in_base

OK, WARN = 0, 1
"""Diagnostic levels (as in diagnostic_msgs/DiagnosticStatus)."""


class OmplPlannerNode(Node):
    def __init__(self):
        super().__init__("ompl_planner")
        params = ConfigParams(self, OmplPlannerNodeConfig, ranges=RANGES, read_only=READ_ONLY)
        self.config = params.config
        self.planner = OmplPlanner(self.config.ompl)
        params.on_set(self._on_set_parameters)
        self.frames = self.config.frames.frames()
        self.joint_names = self.config.frames.joint_names
        self._q: np.ndarray | None = None
        self._q_time = -math.inf
        self.fusion = CloudFusion(self.config.cloud_topics, self.frames, self.config.cloud_max_age_s)
        self._execution_end: float | None = None  # [s] when the executing trajectory ends
        self._state, self._last_error = "idle", ""
        self._last: dict[str, object] = {}

        self.pub_execution = self.create_publisher(JointTrajectory, "joint_trajectory", 10)
        self.pub_traj = self.create_publisher(JointTrajectory, "~/trajectory", 10)
        self.pub_markers = self.create_publisher(MarkerArray, "~/markers", 10)
        self.pub_status = self.create_publisher(DiagnosticArray, "~/status", 10)
        self.pub_diagnostics = self.create_publisher(DiagnosticArray, "/diagnostics", 10)
        self.pub_plan_result = self.create_publisher(DiagnosticStatus, "~/plan_result", 10)
        self.create_subscription(JointState, "joint_states", self._on_joint_states, 10)
        self.cloud_subscriptions = [  # one per topic, its publishers' reliability (nodes/qos.py)
            CloudSubscription(self, cloud_topic, partial(self._on_cloud, cloud_topic))
            for cloud_topic in self.config.cloud_topics
        ]
        self.create_service(GetPlan, "~/plan", self._on_plan)
        self.create_service(GetPlan, "~/plan_grasp", partial(self._on_plan, grasp=True))
        self.grasp_target = GraspTargetInput()
        self.create_subscription(Marker, "grasp_target", self._on_grasp_target, 10)
        pub_owner = self.create_publisher(Header, "execution_owner", OWNER_QOS)
        self.owner = ExecutionOwner(self.get_fully_qualified_name(), pub_owner.publish, self._on_preempted)
        self.create_subscription(Header, "execution_owner", self.owner.on_claim, OWNER_QOS)
        if self.config.execute:
            self.owner.claim()
        self._status_timer = self.create_timer(1.0 / self.config.status_rate_hz, self._publish_status)
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
    def _on_set_parameters(self, changes: dict) -> SetParametersResult:
        """Apply {dotted name: value}: a new config and planner; a status rate change re-creates its timer; turning
        `execute` on claims the arm; read-only parameters never get here."""
        try:
            config = from_params(OmplPlannerNodeConfig, changes, base=self.config)
            planner = OmplPlanner(config.ompl)
        except (ConfigError, ValueError, TypeError) as err:
            return SetParametersResult(successful=False, reason=str(err))
        if config.execute and not self.config.execute:
            self.owner.claim()
        if config.status_rate_hz != self.config.status_rate_hz:
            self._status_timer = self._replace_timer(self._status_timer, config.status_rate_hz, self._publish_status)
        self.config, self.planner = config, planner
        self.fusion.max_age_s = config.cloud_max_age_s
        return SetParametersResult(successful=True)

    def _replace_timer(self, timer, rate_hz: float, callback):
        timer.cancel()
        self.destroy_timer(timer)
        return self.create_timer(1.0 / rate_hz, callback)

    # -- inputs -------------------------------------------------------------------------------------
    def _on_joint_states(self, msg: JointState) -> None:
        try:
            self._q, _ = joint_state_to_q(msg, self.joint_names)
        except AdapterError as err:
            self._error(f"joint_states refused: {err}")
            return
        self._q_time = self._now()

    def _on_cloud(self, cloud_topic: str, msg: PointCloud2) -> None:
        frame = msg.header.frame_id  # an empty frame is taken as world
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

    def _on_grasp_target(self, msg: Marker) -> None:
        """A caller's box around the target of the grasp goals that follow (nodes/grasp_target_input.py)."""
        try:
            self.grasp_target.on_marker(msg, self.frames)
        except (AdapterError, ValueError) as err:
            self._error(f"grasp_target refused: {err}")

    # -- planning -----------------------------------------------------------------------------------
    def _on_plan(self, request: GetPlan.Request, response: GetPlan.Response, grasp: bool = False) -> GetPlan.Response:
        """Plan once (grasp: to a grasp goal, ~/plan_grasp); every request, refused or planned, is answered on
        ~/plan_result as well."""
        response.plan = Path()
        response.plan.header.frame_id = WORLD
        response.plan.header.stamp = self.get_clock().now().to_msg()
        outcome, reason, result = self._plan(request, response, grasp)
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

    def _plan(
        self, request: GetPlan.Request, response: GetPlan.Response, grasp: bool = False
    ) -> tuple[str, str, object]:
        """(outcome, reason, PlanResult or None): SUCCESS fills `response`, publishes and starts the execution."""
        q = self._fresh_q()
        if q is None:
            return REFUSED, "no fresh joint states", None
        try:
            target = pose_stamped_in_base(request.goal, self.frames)
            pos_tol = plan_tolerance(request.tolerance, self.config.pos_tol)
            ori_tol = math.radians(self.config.ori_tol_deg)
            goal = Goal(target.position, target.rotation, pos_tol=pos_tol, ori_tol=ori_tol)
        except (AdapterError, ValueError) as err:
            return REFUSED, str(err), None
        fused = self.fusion.fuse()
        if not fused.sources and (self.config.require_cloud or grasp):
            return REFUSED, "no point cloud received yet", None
        if fused.stale:
            self._error(f"clouds left out as stale: {fused.describe()}")
        self._execution_end = None  # a valid new request ends the watch over the previous execution
        self._state = "planning"
        if grasp:
            spec = self.grasp_target.spec(self.config.grasp_approach_m, self.config.grasp_target_radius_m)
            result = plan_grasp_spec(self.planner, q, goal, fused.points, spec)
        else:
            result = self.planner.plan(q, goal, fused.points if fused.sources else None)
        reason = grasp_reason(result) if grasp else result.reason
        self._last = {
            "last_success": result.success,
            "last_reason": reason,
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
            return FAILED, reason, result
        stamp = response.plan.header.stamp
        positions, quaternions = path_to_world(self.frames, result.ee_positions, result.ee_quaternions)
        response.plan = ee_path_to_path(positions, quaternions, frame_id=WORLD, stamp=stamp)
        timed = jerk_limited_trajectory(result.q_path, self.config.limits)
        arrays = (timed.positions, timed.times, self.joint_names)
        derivatives = {"velocities": timed.velocities, "accelerations": timed.accelerations}
        self.pub_traj.publish(joint_path_to_trajectory(*arrays, stamp=stamp, **derivatives))
        goal_in_world = self.frames.base_to_world(goal.position[None])[0]
        self.pub_markers.publish(path_markers(positions, goal_in_world, stamp, frame_id=WORLD))
        self._state = "planned"
        if self.config.execute:  # stamp 0: the controller starts it on receipt
            self.pub_execution.publish(joint_path_to_trajectory(*arrays, **derivatives))
            self._execution_end = self._now() + timed.duration
            self._state = "executing"
        return SUCCESS, reason, result

    def _fail(self, reason: str) -> None:
        self._state = "failed"
        self._error(reason)

    # -- execution ----------------------------------------------------------------------------------
    def _on_preempted(self, owner: str) -> None:
        """Another node claimed the arm: `execute` off (its trajectory is replaced by the new owner's)."""
        if self.config.execute:
            self.get_logger().warning(f"execute turned off: {owner} claimed the arm on execution_owner")
            self.set_parameters([Parameter("execute", Parameter.Type.BOOL, False)])
        if self._execution_end is not None:
            self._execution_end, self._state = None, "preempted"

    def _publish_status(self) -> None:
        if self._execution_end is not None and self._now() >= self._execution_end:
            self._execution_end, self._state = None, "executed"
        level = WARN if self._state == "failed" else OK
        message = f"{self._state}: {self._last_error}" if self._state == "failed" else self._state
        values = {
            "state": self._state,
            "executing": self._execution_end is not None,
            "execution_owner": self.owner.owner,
            "planner": self.planner.name,
            "last_error": self._last_error,
            "grasp_target": self.grasp_target.describe(self.config.grasp_target_radius_m),
            **self._last,
        }
        stamp = self.get_clock().now().to_msg()
        msg = status_array("ompl_planner", level, message, values, self.planner.name, stamp)
        self.pub_status.publish(msg)
        self.pub_diagnostics.publish(msg)


def main() -> int:
    return run_node("ompl_planner", OmplPlannerNode, (ConfigError, ValueError))


if __name__ == "__main__":
    sys.exit(main())

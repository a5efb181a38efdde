"""planner node: AMP-LS closed-loop joint targets at 10 Hz and one-shot plans on a service.

Subscribes joint_states, goal_pose, grasp_pose (a grasp goal: planning/closed_loop.py), scene_embedding (learned
backend) and each topic of `cloud_topics` (default camera/points; for the geometric backend, the hard check, and the
goal-inside-obstacle check). Only the newest cloud of each topic is converted, once per tick, so fast cameras cannot
starve the control loop; the topics' newest clouds are fused in `world` (perception/cloud_fusion.py: one stamped
more than `cloud_max_age_s` from the newest is left out and named on status; a cloud in another frame is refused
with the topic and reason) and clouds above `cloud_max_points` are voxel-downsampled.
Joint states that are malformed or far outside the joint limits are refused (the last good one goes stale and
commands stop).

Execution (while enabled and given a goal; nothing is commanded without one): at every tick a short jerk-limited
segment to the next target on joint_trajectory (trajectory_msgs/JointTrajectory with velocities and accelerations,
stamped SEGMENT_LEAD_S after it is sent; each segment starts from the state of the one it replaces then, so a
JointTrajectoryController on the same clock, or the sim, follows with continuous velocity; remap it to the
controller's topic), and the same target as a position
setpoint on joint_command (sensor_msgs/JointState: for arms driven by position streaming, and for the monitors that
watch the commands). Enabling claims the arm on execution_owner; a newer claim of another node (ompl_planner with
`execute`) disables the planner (nodes/execution_owner.py). Publishes ~/trajectory (each plan's jerk-limited
trajectory), ~/markers, ~/status (with the last cloud's point counts) and, for every ~/plan request, its outcome on
~/plan_result (diagnostic_msgs/DiagnosticStatus: OK on success, ERROR on a failure or refusal). Services ~/plan
(nav_msgs/GetPlan; `tolerance`: 0 = the planner's pos_tol, a finite positive value [m], anything else refused) and
~/enable (std_srvs/SetBool).

Cylinder obstacles (LSPP): CYLINDER markers on `obstacles` (visualization_msgs/MarkerArray, standing on the
table, see msg_adapters.cylinder_markers) are latched state, kept until DELETE/DELETEALL. While the set is not
empty the closed loop and ~/plan use LSPP (position-only goals; no cloud or embedding needed) and status reports
`mode: lspp (K cylinders; ...)`, else `mode: amp_ls`. A refused array changes nothing. The planner's cylinders
are drawn on ~/markers (namespace `obstacles`). The subscription is volatile: publish after the planner is up.

Parameters: PlannerNodeConfig (config/planner.yaml), validated at once; a bad value is refused with a reason. A change
of the planners' parameters (REBUILT_BY) rebuilds them on a worker thread while the loop goes on ticking; the loop
swaps them in at the start of the first tick after the build (nodes/rebuild_worker.py); other changes apply at once.

    python -m latent_planner_ros run planner [--ros-args --params-file config/planner.yaml]
"""

from __future__ import annotations

import sys
import threading
import time
from dataclasses import replace
from functools import partial, wraps

import numpy as np
import torch
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from geometry_msgs.msg import PoseStamped
from nav_msgs.msg import Path
from nav_msgs.srv import GetPlan
from rcl_interfaces.msg import SetParametersResult
from rclpy.duration import Duration
from rclpy.node import Node
from sensor_msgs.msg import JointState, PointCloud2
from std_msgs.msg import Header
from std_srvs.srv import SetBool
from trajectory_msgs.msg import JointTrajectory
from visualization_msgs.msg import Marker, MarkerArray

from latent_planner_ros.models.checkpoint import CheckpointError
from latent_planner_ros.models.vae_io import load_vae
from latent_planner_ros.nodes.execution_owner import QOS as OWNER_QOS
from latent_planner_ros.nodes.execution_owner import ExecutionOwner
from latent_planner_ros.nodes.grasp_target_input import GraspTargetInput
from latent_planner_ros.nodes.markers import path_markers
from latent_planner_ros.nodes.node_main import run_node
from latent_planner_ros.nodes.planner_config import RANGES, READ_ONLY, PlannerNodeConfig
from latent_planner_ros.nodes.qos import CloudSubscription
from latent_planner_ros.nodes.rebuild_worker import RebuildWorker
from latent_planner_ros.nodes.segment_chain import SEGMENT_LEAD_S, SegmentChain
from latent_planner_ros.nodes.service_thread import ServiceThread
from latent_planner_ros.params.config import ConfigError, from_params
from latent_planner_ros.params.ros import ConfigParams
from latent_planner_ros.perception.cloud_fusion import CloudFusion, CloudRefused, camera_eyes, pose_topic_of
from latent_planner_ros.perception.frames import path_to_world
from latent_planner_ros.perception.scene_input import limit_points
from latent_planner_ros.planning.amp_ls import AmpLs
from latent_planner_ros.planning.backends import CLOUD_SCENE_BACKENDS, make_backend
from latent_planner_ros.planning.closed_loop import ClosedLoopController, TickOutcome
from latent_planner_ros.planning.cylinder_backend import CylinderBackend
from latent_planner_ros.planning.goal import Goal
from latent_planner_ros.planning.goal_reachability import refused_result
from latent_planner_ros.planning.grasp import grasp_reason, plan_grasp_spec
from latent_planner_ros.planning.lspp import make_lspp
from latent_planner_ros.planning.plan_process import PlanProcess, PlanProcessError, PlanSpec
from latent_planner_ros.planning.plan_runner import PlanRequest, ThreadedPlanRunner, planning_function
from latent_planner_ros.planning.planner_modes import LSPP, PlannerModes
from latent_planner_ros.planning.result import PlanResult
from latent_planner_ros.planning.time_parameterisation import jerk_limited_trajectory
from msg_adapters import (
    AdapterError,
    apply_marker_array,
    cloud_to_embedding,
    cloud_to_xyz,
    cylinders_to_array,
    cylinders_to_marker_array,
    ee_path_to_path,
    joint_path_to_trajectory,
    joint_state_to_q,
    plan_result_status,
    plan_tolerance,
    q_to_joint_state,
    status_array,
)
from msg_adapters.plan_request import FAILED, REFUSED, SUCCESS
from msg_adapters.pose import pose_stamped_in_base, pose_stamped_to_target

REBUILT_BY = (
    "vae_checkpoint",
    "collision_checkpoint",
    "lspp_checkpoint",
    "lspp_check",
    "closed_loop",
    "amp_ls",
    "lspp",
)
"""PlannerNodeConfig fields the planners are built from: a change rebuilds them (off the control loop)."""


def _plan_spec(config: PlannerNodeConfig) -> PlanSpec:
    """What the plan process builds its planner from: the AMP-LS planning instance of config."""
    return PlanSpec(
        config.amp_ls_config(), config.amp_ls.collision_backend, config.collision_checkpoint, config.vae_checkpoint
    )


def _planner_fields(config: PlannerNodeConfig) -> dict:
    return {name: getattr(config, name) for name in REBUILT_BY}


FAR_M = 100.0
"""[m] cloud points with a coordinate beyond this are dropped: far out of the arm's reach, and finite outliers
(3e38 from a broken driver) overflowed the collision check's occupancy grid"""


def _locked(method):
    """Run the method under the node's state lock (the control callbacks against ~/plan and parameter swaps)."""

    @wraps(method)
    def run(self, *args):
        with self._lock:
            return method(self, *args)

    return run


class PlannerNode(Node):
    def __init__(self):
        super().__init__("planner")
        torch.set_num_threads(1)  # small batches: threads only add contention with the sim and the encoder
        sys.setswitchinterval(0.001)  # a background plan holds the GIL for at most 1 ms at a time, not 5
        # the control loop, its inputs and parameter changes on the node's executor; ~/plan and ~/plan_grasp on a
        # thread of their own (nodes/service_thread.py: they plan while the loop ticks); _lock guards the state
        # they share (held briefly, never while planning)
        self._lock = threading.RLock()
        self._plan_lock = threading.Lock()  # one plan at a time on the planning instance
        params = ConfigParams(self, PlannerNodeConfig, ranges=RANGES, read_only=READ_ONLY)
        self.config = params.config
        self.frames, self.joint_names = self.config.frames.frames(), self.config.frames.joint_names
        self.vae, _ = load_vae(self.config.vae_checkpoint or None)
        self.plan_process = PlanProcess() if self.config.plan_process else None
        self.modes, self.plan_planner = self._make_modes(self.config, self.vae)
        self._accepted = (self.config, self.vae)  # the newest accepted configuration (its planners may be building)
        self._rebuild = RebuildWorker(self._build, name="planner-rebuild")
        self._last_q: tuple[np.ndarray, float] | None = None  # the last accepted joint state and its time [s]
        params.on_set(self._on_set_parameters)
        self._last_error = ""
        self._last_outcome = TickOutcome(None, "starting", "starting")
        self._cloud_msgs: dict[str, PointCloud2] = {}  # the newest cloud of each topic, not yet converted
        self._cloud_time = 0.0
        self.fusion = CloudFusion(self.config.cloud_topics, self.frames, self.config.cloud_max_age_s)
        self._cloud_sources = "none"
        self._last_cloud = None  # the last converted cloud: points (N, 3), receipt [s], camera topics, their eyes
        self._cloud_points = (0, 0)  # points received, points used (finite, downsampled) of the last cloud
        self._cylinders: dict = {}  # {(ns, id): (x, y, h, r) [m]} of the accepted obstacle markers
        self._obstacle_notes = ""
        self._markers_published = 0  # obstacle markers drawn on ~/markers so far

        self.pub_command = self.create_publisher(JointState, "joint_command", 10)
        self.pub_execution = self.create_publisher(JointTrajectory, "joint_trajectory", 10)
        self.pub_traj = self.create_publisher(JointTrajectory, "~/trajectory", 10)
        self.pub_markers = self.create_publisher(MarkerArray, "~/markers", 10)
        self.pub_status = self.create_publisher(DiagnosticArray, "~/status", 10)
        self.pub_plan_result = self.create_publisher(DiagnosticStatus, "~/plan_result", 10)
        self.pub_diagnostics = self.create_publisher(DiagnosticArray, "/diagnostics", 10)
        self.create_subscription(JointState, "joint_states", self._on_joint_states, 10)
        self.create_subscription(PoseStamped, "goal_pose", self._on_goal, 10)
        self.create_subscription(PoseStamped, "grasp_pose", self._on_grasp_goal, 10)
        self.grasp_target = GraspTargetInput()
        self.create_subscription(Marker, "grasp_target", self._on_grasp_target, 10)
        self.cloud_subscriptions = [  # one per topic, its publishers' reliability (nodes/qos.py)
            CloudSubscription(self, cloud_topic, partial(self._on_cloud, cloud_topic))
            for cloud_topic in self.config.cloud_topics
        ]
        for cloud_topic in self.config.cloud_topics:  # each camera's optical centre, beside its cloud
            pose_topic = pose_topic_of(cloud_topic)
            self.create_subscription(PoseStamped, pose_topic, partial(self._on_camera_pose, cloud_topic), 10)
        self.create_subscription(MarkerArray, "obstacles", self._on_obstacles, 10)
        if self.config.amp_ls.collision_backend == "learned":
            self.create_subscription(PointCloud2, "scene_embedding", self._on_embedding, 2)
        self.service_thread = ServiceThread(self)
        self.service_thread.create_service(GetPlan, "~/plan", self._on_plan)
        self.service_thread.create_service(GetPlan, "~/plan_grasp", partial(self._on_plan, grasp=True))
        self.create_service(SetBool, "~/enable", self._on_enable)
        self.segments = SegmentChain()
        pub_owner = self.create_publisher(Header, "execution_owner", OWNER_QOS)
        self.owner = ExecutionOwner(self.get_fully_qualified_name(), pub_owner.publish, self._on_preempted)
        self.create_subscription(Header, "execution_owner", self.owner.on_claim, OWNER_QOS)
        if self.config.enabled:
            self.owner.claim()
        self._tick_timer = self.create_timer(1.0 / self.config.closed_loop.rate_hz, self._on_tick)
        self._status_timer = self.create_timer(1.0 / self.config.status_rate_hz, self._publish_status)
        self.get_logger().info(
            f"AMP-LS ready: backend {self.config.amp_ls.collision_backend} (LSPP on cylinder obstacles), "
            f"{self.config.closed_loop.rate_hz:.0f} Hz, enabled={self.config.enabled}"
        )

    def destroy_node(self) -> None:
        self._rebuild.close()
        self.service_thread.close()
        if self.plan_process is not None:
            self.plan_process.close()
        super().destroy_node()

    def _make_modes(self, config: PlannerNodeConfig, vae) -> tuple[PlannerModes, AmpLs]:
        """The AMP-LS and LSPP closed loops, and the AMP-LS instance that plans (the closed loop's background plans
        and ~/plan, on a backend of its own); CheckpointError for a missing or bad checkpoint."""

        def amp_ls() -> AmpLs:
            backend = make_backend(config.amp_ls.collision_backend, config.collision_checkpoint)
            return AmpLs(vae, backend, config.amp_ls_config())

        plan_planner, stepping = amp_ls(), amp_ls()
        lspp = make_lspp(vae, config.lspp_config(), config.lspp_checkpoint or None, config.lspp_check)
        for planner in (stepping, lspp, plan_planner):
            planner.warm_up()
        if self.plan_process is not None:  # the background plans in the child process, with the same planner
            spec = _plan_spec(config)
            self.plan_process.prepare(spec)
            runner = ThreadedPlanRunner(self.plan_process.plan_fn(spec))
        else:
            runner = ThreadedPlanRunner(planning_function(plan_planner, self._plan_lock))
        modes = PlannerModes(
            ClosedLoopController(stepping, config.closed_loop_config(), runner),
            ClosedLoopController(lspp, config.closed_loop_config()),
        )
        modes.set_enabled(config.enabled)
        return modes, plan_planner

    def _now(self) -> float:
        return self.get_clock().now().nanoseconds * 1e-9

    def _error(self, text: str) -> None:
        self._last_error = text
        self.get_logger().warning(text, throttle_duration_sec=1.0)

    # -- parameters ------------------------------------------------------------------------------
    def _on_set_parameters(self, ours: dict) -> SetParametersResult:
        """Check {dotted name: value} of our parameters here, so a bad value is refused with its reason; a change of
        the planners' fields (REBUILT_BY) is built on the rebuild worker and swapped in at a tick, the rest applies
        at once (read-only parameters never get here, nor use_sim_time)."""
        with self._lock:
            base, base_vae = self._accepted
        try:
            config = from_params(PlannerNodeConfig, ours, base=base)
            learned = [c.amp_ls.collision_backend == "learned" for c in (config, base)]
            if learned[0] != learned[1]:  # the scene_embedding subscription exists only with the learned backend
                raise ConfigError("amp_ls.collision_backend: a change to or from learned needs a restart of the node")
            vae = self._checked_checkpoints(config, base, base_vae)
        except (ConfigError, ValueError, TypeError) as err:
            return SetParametersResult(successful=False, reason=str(err))
        with self._lock:
            self._accepted = (config, vae)
            if _planner_fields(config) != _planner_fields(base):
                self._rebuild.submit((config, vae))  # the slow part, while the loop goes on ticking
            self._apply(replace(config, **_planner_fields(self.config)))
            if "enabled" in ours:
                self._set_enabled(config.enabled)
        return SetParametersResult(successful=True)

    def _checked_checkpoints(self, config: PlannerNodeConfig, base: PlannerNodeConfig, base_vae):
        """The VAE of `config`; each changed checkpoint is loaded once to see that it is good (ConfigError naming
        the parameter and the problem)."""

        def load(name: str, loader):
            try:
                return loader()
            except CheckpointError as err:
                raise ConfigError(f"{name}: {err}") from None

        if config.collision_checkpoint != base.collision_checkpoint and config.amp_ls.collision_backend == "learned":
            load("collision_checkpoint", lambda: make_backend("learned", config.collision_checkpoint))
        if config.lspp_checkpoint != base.lspp_checkpoint:
            load("lspp_checkpoint", lambda: CylinderBackend.load(config.lspp_checkpoint or None))
        if config.vae_checkpoint == base.vae_checkpoint:
            return base_vae
        return load("vae_checkpoint", lambda: load_vae(config.vae_checkpoint or None)[0])

    def _build(self, request: tuple[PlannerNodeConfig, object]) -> tuple[PlannerModes, AmpLs]:
        """On the rebuild worker: the planners of an accepted configuration (the slow part of a change)."""
        config, vae = request
        return self._make_modes(config, vae)

    def _take_rebuild(self) -> None:
        """At the start of a tick (under the lock): swap in the planners of the newest change, once built."""
        built = self._rebuild.take()
        if built is None:
            return
        if built.error is not None:  # checked when accepted; a checkpoint file that went away since, say
            self._error(f"parameter change not applied: rebuilding the planners failed: {built.error}")
            return
        config, vae = built.request
        modes, plan_planner = built.result
        modes.set_enabled(self.modes.amp_ls.enabled)  # as ~/enable, a preemption or `enabled` left it
        accepted = replace(self._accepted[0], **_planner_fields(config))
        self._swap(accepted, vae, modes, plan_planner)

    def _apply(self, config: PlannerNodeConfig) -> None:
        """Take up config (under the lock) with the planners in use: rates re-create their timers."""
        if config.closed_loop.rate_hz != self.config.closed_loop.rate_hz:  # the step size follows the rate
            self._tick_timer = self._replace_timer(self._tick_timer, config.closed_loop.rate_hz, self._on_tick)
        if config.status_rate_hz != self.config.status_rate_hz:
            self._status_timer = self._replace_timer(self._status_timer, config.status_rate_hz, self._publish_status)
        self.fusion.max_age_s = config.cloud_max_age_s
        self.config = config

    def _set_enabled(self, enabled: bool) -> None:
        if enabled:
            self.owner.claim()  # the other execution source stops
        else:
            self.segments.reset()
        self.modes.set_enabled(enabled)

    def _swap(self, config: PlannerNodeConfig, vae, modes: PlannerModes, plan_planner: AmpLs) -> None:
        """Take up rebuilt planners and their configuration: the inputs, goal (a grasp goal as a grasp) and cylinders
        carry over."""
        goal, grasp, cylinders = self.modes.goal, self.modes.grasp, self.modes.cylinders
        old_runner = self.modes.amp_ls.follower.runner if self.modes.amp_ls.follower is not None else None
        self._apply(config)
        self.modes, self.vae, self.plan_planner = modes, vae, plan_planner
        if old_runner is not None:
            old_runner.close(timeout_s=0.0)  # its thread ends after the plan it runs; that outcome is dropped
        if self._last_q is not None:
            self.modes.set_joint_state(*self._last_q)
        if self._last_cloud is not None:
            self._apply_cloud(*self._last_cloud)
        self.modes.set_cylinders(cylinders, self._now())
        if goal is not None:
            self.modes.set_goal(goal, self._now(), grasp)
            if grasp is not None and self._last_cloud is not None:  # the target's points set aside again
                self._apply_cloud(*self._last_cloud)

    def _replace_timer(self, timer, rate_hz: float, callback):
        timer.cancel()
        self.destroy_timer(timer)
        return self.create_timer(1.0 / rate_hz, callback)

    # -- inputs -------------------------------------------------------------------------------------
    @_locked
    def _on_joint_states(self, msg: JointState) -> None:
        try:
            q, _ = joint_state_to_q(msg, self.joint_names)
        except AdapterError as err:
            self._error(f"joint_states refused: {err}")
            return
        now = self._now()
        accepted, reason = self.modes.set_joint_state(q, now)
        if accepted:
            self._last_q = (q, now)
        else:
            self._error(f"joint_states refused: {reason}")

    @_locked
    def _on_camera_pose(self, cloud_topic: str, msg: PoseStamped) -> None:
        """A camera's optical centre (`<ns>/pose` beside `<ns>/points`): the goal checks see along its rays."""
        try:
            pose = pose_stamped_to_target(msg, expected_frame=None)  # the fusion moves it into the base frame
            stamp = msg.header.stamp.sec + msg.header.stamp.nanosec * 1e-9
            self.fusion.add_pose(cloud_topic, pose.position, msg.header.frame_id, stamp)
        except (AdapterError, CloudRefused) as err:  # the previous origin stays
            self._error(str(err) if isinstance(err, CloudRefused) else f"{pose_topic_of(cloud_topic)} refused: {err}")

    def _on_cloud(self, cloud_topic: str, msg: PointCloud2) -> None:
        """Keep the topic's newest cloud; it is converted once, at the next tick, goal or plan request (clouds
        faster than the control rate would otherwise starve the control loop)."""
        self._cloud_msgs[cloud_topic], self._cloud_time = msg, self._now()

    def _use_latest_cloud(self) -> None:
        msgs, self._cloud_msgs = self._cloud_msgs, {}
        accepted = False
        for topic, msg in msgs.items():
            try:
                self.fusion.check(topic, msg.header.frame_id)
                points = cloud_to_xyz(msg)
                stamp = msg.header.stamp.sec + msg.header.stamp.nanosec * 1e-9
                self.fusion.add_cloud(topic, points, msg.header.frame_id, stamp, int(msg.width) * int(msg.height))
                accepted = True
            except CloudRefused as err:
                self._error(str(err))
            except AdapterError as err:
                self._error(f"{topic} refused: {err}")
        if not accepted:
            return
        fused = self.fusion.fuse()
        self._cloud_sources = fused.describe()
        if fused.stale:
            self._error(f"clouds left out as stale: {', '.join(fused.stale)}")
        near = fused.points[np.all(np.abs(fused.points) <= FAR_M, axis=1)]
        cloud, _ = limit_points(near, self.config.cloud_max_points, self.config.cloud_voxel_m)
        self._cloud_points = (sum(self.fusion.received[t] for t in fused.sources), len(cloud))
        eyes = camera_eyes(fused.origins)
        self._last_cloud = (cloud, self._cloud_time, max(1, len(fused.sources)), eyes)
        self._apply_cloud(*self._last_cloud)

    def _camera_poses_known(self) -> int:
        """How many cameras' optical centres the last fused cloud is seen from (0: none known, so the hidden-goal
        rule cannot apply; a camera publishes its pose on `<ns>/pose`)."""
        eyes = None if self._last_cloud is None else self._last_cloud[3]
        return 0 if eyes is None else len(eyes)

    def _apply_cloud(self, cloud, received: float, views: int = 1, eyes: np.ndarray | None = None) -> None:
        """Hand a cloud (N, 3) [m] received at `received` [s], fused from `views` camera topics seen from `eyes`
        (K, 3) [m] (None: unknown), to the AMP-LS backend and the goal checks."""
        self.modes.lspp.set_cloud(cloud, eyes=eyes)  # LSPP plans around the cylinders; the cloud only checks goals
        controller = self.modes.amp_ls
        backend = controller.planner.backend
        obstacles = controller.set_cloud(cloud, received, views, eyes)  # at a grasp goal without the target's points
        if backend.name in CLOUD_SCENE_BACKENDS:
            controller.set_scene(obstacles, received)
            return
        backend.set_cloud(obstacles, views)  # learned: the raw cloud feeds the hard check of each step

    @_locked
    def _on_embedding(self, msg: PointCloud2) -> None:
        try:
            centres, features = cloud_to_embedding(msg)
            embedding = self.modes.amp_ls.planner.backend.embedding_from_points(centres, features)
        except (AdapterError, ValueError) as err:
            self._error(f"scene_embedding refused: {err}")
            return
        self.modes.amp_ls.set_scene(embedding, self._now())

    @_locked
    def _on_obstacles(self, msg: MarkerArray) -> None:
        """Apply CYLINDER markers to the obstacle set; a refused array leaves the set as it was."""
        cfg = self.config
        before = self.modes.describe()
        try:
            update = apply_marker_array(
                msg, self._cylinders, cfg.tuning.obstacle_tilt_tol_deg, cfg.tuning.obstacle_z_tol_m
            )
            cylinders = cylinders_to_array(update.cylinders)
            dropped = self.modes.set_cylinders(cylinders, self._now())
        except (AdapterError, ValueError) as err:
            self._error(f"obstacles refused: {err}")
            return
        self._cylinders, self._obstacle_notes = update.cylinders, "; ".join(update.notes)
        if dropped:
            self._error(f"goal dropped: {dropped}")
        if self.modes.describe() != before:
            self.get_logger().info(f"mode: {self.modes.describe()}")
        stamp = self.get_clock().now().to_msg()
        self.pub_markers.publish(cylinders_to_marker_array(cylinders, stamp=stamp, previous=self._markers_published))
        self._markers_published = len(cylinders)

    def _goal_from(self, msg: PoseStamped, tolerance: float = 0.0) -> Goal:
        target = pose_stamped_in_base(msg, self.frames)  # world, base or extrinsic frame -> base frame
        cfg = self.modes.active.planner.config
        pos_tol = plan_tolerance(tolerance, cfg.pos_tol)
        return Goal(target.position, target.rotation, pos_tol=pos_tol, ori_tol=cfg.ori_tol)

    @_locked
    def _on_goal(self, msg: PoseStamped) -> None:
        self._take_goal(msg, grasp=False)

    @_locked
    def _on_grasp_goal(self, msg: PoseStamped) -> None:
        self._take_goal(msg, grasp=True)

    @_locked
    def _on_grasp_target(self, msg: Marker) -> None:
        """A caller's box around the target of the grasp goals that follow (nodes/grasp_target_input.py)."""
        try:
            self.grasp_target.on_marker(msg, self.frames)
        except (AdapterError, ValueError) as err:
            self._error(f"grasp_target refused: {err}")

    def _take_goal(self, msg: PoseStamped, grasp: bool) -> None:
        """goal_pose, or (grasp) grasp_pose: a grasp goal with the grasp_approach_m and grasp_target_radius_m
        parameters (planning/closed_loop.py: its target's points set aside, reached along a background plan)."""
        topic = "grasp_pose" if grasp else "goal_pose"
        try:
            goal = self._goal_from(msg)
            cfg = self.config
            spec = self.grasp_target.spec(cfg.grasp_approach_m, cfg.grasp_target_radius_m) if grasp else None
        except (AdapterError, ValueError) as err:
            self._error(f"{topic} refused: {err}")
            return
        self._use_latest_cloud()
        accepted, reason = self.modes.set_goal(goal, self._now(), spec)
        if not accepted:
            self._error(reason)
        elif self._last_cloud is not None:  # the target is set aside from (or back in) the checked cloud
            self._apply_cloud(*self._last_cloud)

    # -- control ------------------------------------------------------------------------------------
    def _on_tick(self) -> None:
        with self._lock:
            self._take_rebuild()
            self._use_latest_cloud()
            now = self._now()
            outcome = self.modes.tick(now)
            self._last_outcome = outcome
            q = self.modes.active.fresh_joint_state(now) if outcome.command is not None else None
            limits, period = self.config.limits, 1.0 / self.config.closed_loop.rate_hz
        if outcome.command is None:
            return
        # the segment starts SEGMENT_LEAD_S after it is sent (not when the tick began): the chain takes the running
        # segment's state then and the stamp says so; a controller that has it by then switches at that instant, one
        # that gets it later joins it where it is by then (with stamp 0, start on receipt, the command went back to
        # the segment's start: a jolt of the arm)
        start = self.get_clock().now() + Duration(nanoseconds=int(SEGMENT_LEAD_S * 1e9))
        segment = self.segments.next(
            start.nanoseconds * 1e-9, outcome.command, outcome.command if q is None else q, limits, period
        )
        self.pub_execution.publish(
            joint_path_to_trajectory(
                segment.positions,
                segment.times,
                names=self.joint_names,
                velocities=segment.velocities,
                accelerations=segment.accelerations,
                stamp=start.to_msg(),
            )
        )
        stamp = self.get_clock().now().to_msg()
        self.pub_command.publish(q_to_joint_state(outcome.command, names=self.joint_names, stamp=stamp))

    @_locked
    def _on_preempted(self, owner: str) -> None:
        """Another node claimed the arm: stop commanding (call ~/enable to take it back)."""
        if self.modes.active.enabled:
            self.get_logger().warning(f"disabled: {owner} claimed the arm on execution_owner")
        self.modes.set_enabled(False)
        self.segments.reset()

    def _on_enable(self, request: SetBool.Request, response: SetBool.Response) -> SetBool.Response:
        with self._lock:
            self._set_enabled(bool(request.data))
        response.success, response.message = True, "enabled" if request.data else "disabled"
        return response

    def _on_plan(self, request: GetPlan.Request, response: GetPlan.Response, grasp: bool = False) -> GetPlan.Response:
        """Plan once (grasp: to a grasp goal, ~/plan_grasp); every request, refused or planned, is answered on
        ~/plan_result as well."""
        response.plan = Path()
        response.plan.header.frame_id = "world"
        response.plan.header.stamp = self.get_clock().now().to_msg()
        outcome, reason, result = self._plan(request, response, grasp)
        if outcome == REFUSED:
            self._error(f"plan refused: {reason}")
        elif outcome == FAILED:
            self._error(f"plan failed: {reason} (error {result.final_pos_err_m * 1000:.0f} mm)")
        else:
            self._last_error = ""  # a successful plan clears the error of an earlier one
        timing = (result.planning_time_s, result.final_pos_err_m) if result is not None else (None, None)
        stamp, waypoints = request.goal.header.stamp, len(response.plan.poses)
        self.pub_plan_result.publish(plan_result_status(self.get_name(), outcome, reason, stamp, waypoints, *timing))
        return response

    def _plan_inputs(self, request: GetPlan.Request, grasp: bool = False) -> tuple[str, object]:
        """("", (PlanRequest, planner, lspp)) for a plan, or (reason, None) for a refusal; takes the inputs under
        the lock, briefly. A grasp goal lies at an object: no goal-inside-obstacle check, a cloud is needed."""
        with self._lock:
            controller = self.modes.active
            q = controller.fresh_joint_state(self._now())
            if q is None:
                return "no fresh joint states", None
            try:
                goal = self._goal_from(request.goal, float(request.tolerance))
            except (AdapterError, ValueError) as err:
                return str(err), None
            self._use_latest_cloud()
            lspp = self.modes.mode == LSPP
            if grasp and (lspp or controller.cloud is None):
                return "grasp goals need a point cloud (and no cylinder obstacles)", None
            ok, reason = controller.check_goal(goal, check_cloud=False) if grasp else self.modes.check_goal(goal)
            if not ok:
                return "goal " + reason.removeprefix("goal refused: "), None
            planner = controller.planner if lspp else self.plan_planner
            scene = controller.scene if planner.config.use_collision else None
            if planner.config.use_collision and scene is None:
                return "no scene received yet", None
            cloud = controller.raw_cloud  # the whole cloud: a grasp goal of the closed loop sets nothing aside here
            if scene is not None and not lspp and planner.backend.name in CLOUD_SCENE_BACKENDS:
                scene = cloud
            cfg = self.config
            spec = self.grasp_target.spec(cfg.grasp_approach_m, cfg.grasp_target_radius_m) if grasp else None
            views, eyes = controller.cloud_views, controller.cloud_eyes
            return "", (PlanRequest(q, goal, scene, cloud, 0, spec, views, eyes), planner, lspp)

    def _plan(
        self, request: GetPlan.Request, response: GetPlan.Response, grasp: bool = False
    ) -> tuple[str, str, object]:
        """(outcome, reason, PlanResult or None): SUCCESS fills `response` and publishes the trajectory. AMP-LS
        plans on its planning instance while the closed loop goes on ticking; LSPP plans on the closed loop's
        own instance, so the loop waits for it (LSPP plans take tens of milliseconds)."""
        refusal, inputs = self._plan_inputs(request, grasp)
        if inputs is None:
            return REFUSED, refusal, None
        plan_request, planner, lspp = inputs
        goal = plan_request.goal
        t0 = time.perf_counter()
        if grasp:
            with self._plan_lock:
                q, cloud = plan_request.q, plan_request.cloud
                result = plan_grasp_spec(planner, q, goal, cloud, plan_request.grasp)
        elif lspp:
            with self._lock:
                result = planner.plan(plan_request.q, goal, plan_request.scene)
        else:
            result = self._plan_one_shot(planner, plan_request)
        self.get_logger().info(
            f"plan ({planner.name}): {'success' if result.success else 'failure'} ({result.reason}) "
            f"in {time.perf_counter() - t0:.3f} s, "
            f"{len(result.q_path)} states, error {result.final_pos_err_m * 1000:.1f} mm"
        )
        reason = grasp_reason(result) if grasp else result.reason
        if not result.success:
            return FAILED, reason, result
        stamp = response.plan.header.stamp
        positions, quaternions = path_to_world(self.frames, result.ee_positions, result.ee_quaternions)
        response.plan = ee_path_to_path(positions, quaternions, frame_id="world", stamp=stamp)
        timed = jerk_limited_trajectory(result.q_path, self.config.limits)
        self.pub_traj.publish(
            joint_path_to_trajectory(
                timed.positions,
                timed.times,
                names=self.joint_names,
                stamp=stamp,
                velocities=timed.velocities,
                accelerations=timed.accelerations,
            )
        )
        goal_world = path_to_world(self.frames, goal.position[None], np.array([[0.0, 0.0, 0.0, 1.0]]))[0][0]
        self.pub_markers.publish(path_markers(positions, goal_world, stamp))
        return SUCCESS, reason, result

    def _plan_one_shot(self, planner: AmpLs, request: PlanRequest) -> PlanResult:
        """An AMP-LS plan for ~/plan: in the plan process when there is one (its planner is built from the
        configuration of the planners in use), else on this thread under the planning lock."""
        if self.plan_process is None:
            return planning_function(planner, self._plan_lock)(request)
        t0 = time.perf_counter()
        try:
            result = self.plan_process.call(_plan_spec(self.config), request)
        except PlanProcessError as err:
            return refused_result(planner.panda, request.q, request.goal, f"planning failed: {err}", t0)
        assert result is not None  # a request gets a result or raises
        return result

    def _link_p_collision(self) -> dict[str, float]:
        """{link: p(collision)} the active backend gives the measured joint state ({} without one, or in LSPP)."""
        backend = self.modes.active.planner.backend
        q = self.modes.active.fresh_joint_state(self._now())
        if q is None:
            return {}
        return backend.link_p_collision(q)

    def _background_plans(self) -> str:
        """Where the closed loop's background plans run: "process <pid>" (once the child is up) or "thread"."""
        if self.plan_process is None:
            return "thread"
        pid = self.plan_process.pid
        return "process (starting)" if pid is None else f"process {pid}"

    @_locked
    def _publish_status(self) -> None:
        o = self._last_outcome
        points_in, points_used = self._cloud_points
        values = {
            "state": o.state,
            "mode": self.modes.describe(),
            "collision_backend": self.modes.active.planner.backend.mode,
            "obstacles_note": self._obstacle_notes,
            "last_error": self._last_error,
            "cloud_points_in": points_in,
            "cloud_points_used": points_used,
            "cloud_sources": self._cloud_sources,
            "camera_poses": self._camera_poses_known(),
            "cloud_qos": ", ".join(s.describe() for s in self.cloud_subscriptions),
            "execution_owner": self.owner.owner,
            "background_plans": self._background_plans(),
            "grasp": self.modes.amp_ls.grasp_note if self.modes.grasp is not None else "",
            "grasp_target": self.grasp_target.describe(self.config.grasp_target_radius_m),
            **o.values,
        }
        links = self._link_p_collision()
        if links:
            values["p_collision_links"] = " ".join(f"{name}={p:.3f}" for name, p in links.items())
        stamp = self.get_clock().now().to_msg()
        msg = status_array("planner", o.level, f"{o.state}: {o.reason}", values, self.modes.active.planner.name, stamp)
        self.pub_status.publish(msg)
        self.pub_diagnostics.publish(msg)


def main() -> int:
    return run_node("planner", PlannerNode, (CheckpointError, ConfigError, ValueError))


if __name__ == "__main__":
    sys.exit(main())

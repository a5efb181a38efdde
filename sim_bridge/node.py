"""The ``sim`` node: the MuJoCo Panda world on ROS 2.

Publishes ``joint_states`` (100 Hz), ``/clock``, ``sim/in_collision`` (at the joint-state rate: true if the
arm touched the scene during the period) and ``sim/min_distance`` (std_msgs/Float64 at the joint-state rate:
the arm's ground-truth clearance [m] to the scenario objects, the table excluded, negative when
penetrating, capped at ``sim.DISTANCE_CUTOFF_M``), for each depth camera ``<name>`` its cloud on
``<name>/points`` and its optical centre and orientation on ``<name>/pose`` (with the cloud's stamp; the
default single camera ``camera``: ``camera/points`` and ``camera/pose``; sim_bridge/camera_rig.py), and
``target_pose`` (12.5 Hz); subscribes
``joint_trajectory`` (trajectory_msgs/JointTrajectory, executed as a JointTrajectoryController does: from the
header stamp, 0 = on receipt, replacing the current trajectory from the commanded state; remappable) and
``joint_command`` (sensor_msgs/JointState position targets, refused while a trajectory runs: one source at a
time, see sim_bridge/sim.py); serves ``sim/reset``. Rates are in simulated time; stamps are simulated time (run
other nodes with ``use_sim_time:=true``). Parameters: :class:`~sim_bridge.sim_config.SimConfig` (see
``config/sim.yaml``) and, for every listed camera other than ``camera``, ``<name>.*`` (CameraConfig, each
defaulting to the ``camera.*`` value); they take effect at the next ``sim/reset``, except ``real_time_factor``
(at once) and ``cameras`` (the list is fixed at start-up).

    python -m latent_planner_ros run sim [--record out.gif | --record frames/] [--duration S] \
        [--ros-args -p scenario:=conveyor -p real_time_factor:=0 --params-file config/sim.yaml]

The single thread steps the physics, publishes, and serves callbacks while it waits for the wall clock.
"""

from __future__ import annotations

import argparse
import sys
from dataclasses import replace
from pathlib import Path

import rclpy
from geometry_msgs.msg import PoseStamped
from rcl_interfaces.msg import SetParametersResult
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from rclpy.logging import get_logger
from rclpy.node import Node
from rclpy.time import Time as RosTime
from rclpy.utilities import remove_ros_args
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import JointState, PointCloud2
from std_msgs.msg import Bool, Float64
from std_srvs.srv import Trigger
from trajectory_msgs.msg import JointTrajectory

from latent_planner_ros.params.config import ConfigError, from_params
from latent_planner_ros.params.ros import ConfigParams
from latent_planner_ros.params.specs import param_specs
from latent_planner_ros.robot.limits import JOINT_NAMES
from msg_adapters import (
    AdapterError,
    joint_state_to_q,
    q_to_joint_state,
    target_to_pose_stamped,
    trajectory_to_execution,
    xyz_to_cloud,
)
from sim_bridge.camera_config import CameraConfig
from sim_bridge.camera_rig import DEFAULT_CAMERA, camera_from_params
from sim_bridge.mjcf import DEPTH_CAMERA, OVERVIEW_CAMERA
from sim_bridge.render import Recorder, Snapshotter
from sim_bridge.runner import Runner, Tick
from sim_bridge.scenario import Scenario, ScenarioError
from sim_bridge.scenario_files import load_scenario, parse_overrides
from sim_bridge.sim import TRAJECTORY, Sim
from sim_bridge.sim_config import SimConfig
from sim_bridge.sim_ranges import SIM_RANGES, SIM_READ_ONLY


def _stamp(seconds: float):
    return RosTime(nanoseconds=round(seconds * 1e9)).to_msg()


def scenario_of(config: SimConfig) -> Scenario:
    """The scenario the config names (ScenarioError naming the file and field if it is bad)."""
    seed = None if config.seed < 0 else config.seed
    return load_scenario(config.scenario, seed=seed, overrides=parse_overrides(config.scenario_overrides))


class SimNode(Node):
    """Wires a :class:`Sim` and its :class:`Runner` to topics, a service and parameters.

    Raises ConfigError or ScenarioError from the constructor when the initial parameters are bad.
    """

    def __init__(self, frame_rate: float = 0.0, **kwargs):
        super().__init__("sim", **kwargs)
        params = ConfigParams(self, SimConfig, ranges=SIM_RANGES, read_only=SIM_READ_ONLY)
        self._param_names = params.names
        self.config = params.config
        self._camera_params: dict[str, str] = {}  # <name>.<field> -> camera name, of the listed cameras but `camera`
        self.named_cameras: dict[str, CameraConfig] = {}
        fields = param_specs(self.config.camera, SIM_RANGES)  # camera.*: the types, ranges and docs of each group
        for camera in self.config.cameras:
            if camera == DEFAULT_CAMERA:
                continue
            specs = {f"{camera}.{f}": replace(spec, name=f"{camera}.{f}") for f, spec in fields.items()}
            values = params.declare(specs)  # defaults: the camera.* values
            self._camera_params.update(dict.fromkeys(specs, camera))
            self.named_cameras[camera] = camera_from_params(camera, values, self.config.camera)
        self.sim = Sim(scenario_of(self.config), self.config, self.named_cameras)
        self.runner = Runner(self.sim, frame_rate=frame_rate)
        params.on_set(self._on_set_parameters)
        self.add_on_set_parameters_callback(self._on_set_camera_parameters)

        self._pub_joints = self.create_publisher(JointState, "joint_states", 10)
        self._pub_clock = self.create_publisher(Clock, "/clock", 10)
        self._pub_collision = self.create_publisher(Bool, "sim/in_collision", 10)
        self._pub_cameras: dict[str, tuple] = {}  # camera name -> (cloud, pose) publishers, made as cameras appear
        self._pub_target = self.create_publisher(PoseStamped, "target_pose", 10)
        self._pub_distance = self.create_publisher(Float64, "sim/min_distance", 10)
        self.create_subscription(JointState, "joint_command", self._on_command, 10)
        self.create_subscription(JointTrajectory, "joint_trajectory", self._on_trajectory, 10)
        self._source = self.sim.source  # the command source last logged
        self.create_service(Trigger, "sim/reset", self._on_reset)
        self._was_colliding = False
        self._warned: set[str] = set()
        self._describe()

    def _describe(self) -> None:
        s = self.sim.scenario
        self.get_logger().info(
            f"scenario {s.name!r}: {len(s.objects)} objects, target {'yes' if s.target else 'no'}; {s.description}"
        )
        cameras = ", ".join(f"{c.name} ({c.source}) on {c.points_topic}" for c in self.sim.rig)
        self.get_logger().info(f"depth cameras: {cameras}")
        for camera in self.sim.rig:
            self._camera_publishers(camera.name)

    def _camera_publishers(self, camera: str) -> tuple:
        """The (cloud, pose) publishers of depth camera `camera`: <camera>/points and <camera>/pose."""
        if camera not in self._pub_cameras:
            self._pub_cameras[camera] = (
                self.create_publisher(PointCloud2, f"{camera}/points", 2),
                self.create_publisher(PoseStamped, f"{camera}/pose", 10),
            )
        return self._pub_cameras[camera]

    # ------------------------------------------------------------------ callbacks
    def _on_set_parameters(self, ours: dict) -> SetParametersResult:
        """Apply {dotted name: value} of SimConfig parameters (`cameras` is read-only)."""
        try:
            config = from_params(SimConfig, ours, base=self.config)
            if {"scenario", "scenario_overrides"} & set(ours):
                scenario_of(config)  # refuse a scenario that would not load
        except ConfigError as err:
            return SetParametersResult(successful=False, reason=str(err))
        except ScenarioError as err:  # named by the parameter that was set
            name = "scenario" if "scenario" in ours else "scenario_overrides"
            reason = str(err) if str(err).startswith(f"{name}:") else f"{name}: {err}"
            return SetParametersResult(successful=False, reason=reason)
        if config.real_time_factor != self.config.real_time_factor:
            self.runner.set_real_time_factor(config.real_time_factor)
        self.config = config
        return SetParametersResult(successful=True)

    def _on_set_camera_parameters(self, params) -> SetParametersResult:
        """Apply the `<camera>.*` parameters of the named cameras (at the next reset)."""
        per_camera = {p.name: p.value for p in params if p.name in self._camera_params}
        named = dict(self.named_cameras)
        try:
            for camera in {self._camera_params[n] for n in per_camera}:
                named[camera] = camera_from_params(camera, per_camera, named[camera])
        except ConfigError as err:
            return SetParametersResult(successful=False, reason=str(err))
        self.named_cameras = named
        return SetParametersResult(successful=True)

    def _on_command(self, msg: JointState) -> None:
        unknown = sorted(set(msg.name) - set(JOINT_NAMES))
        if unknown:
            self.get_logger().warning(f"joint_command refused: unknown joints {unknown}", throttle_duration_sec=1.0)
            return
        try:
            q, _ = joint_state_to_q(msg)
        except AdapterError as err:
            self.get_logger().warning(f"joint_command refused: {err}", throttle_duration_sec=1.0)
            return
        if self.sim.trajectory_owns():  # expected while a planner sends both; not worth a warning
            self.get_logger().debug("joint_command ignored: a joint_trajectory is being executed")
            return
        result = self.sim.set_command(q)
        self._log_source()
        if not result.accepted:
            self.get_logger().warning(f"joint_command refused: {result.reason}", throttle_duration_sec=1.0)
        elif result.clamped:
            self.get_logger().warning(f"joint_command {result.reason}", throttle_duration_sec=1.0)

    def _on_trajectory(self, msg: JointTrajectory) -> None:
        try:
            times, q, dq, ddq = trajectory_to_execution(msg, JOINT_NAMES)
        except AdapterError as err:
            self.get_logger().warning(f"joint_trajectory refused: {err}", throttle_duration_sec=1.0)
            return
        stamp = msg.header.stamp.sec + msg.header.stamp.nanosec * 1e-9  # 0: now
        # the stamp is on the published /clock, which runs on across resets; the sim's own time restarts at each
        reason = self.sim.set_trajectory(times, q, dq, ddq, stamp=self.runner.to_sim_time(stamp) if stamp else 0.0)
        if reason:
            self.get_logger().warning(f"joint_trajectory refused: {reason}", throttle_duration_sec=1.0)
        self._log_source()

    def _log_source(self) -> None:
        if self.sim.source != self._source:
            self._source = self.sim.source
            topic = "joint_trajectory" if self._source == TRAJECTORY else "joint_command"
            self.get_logger().info(f"command source: {topic}")

    def _on_reset(self, request: Trigger.Request, response: Trigger.Response) -> Trigger.Response:
        previous = self.sim.config
        try:
            scenario = scenario_of(self.config)
            self.sim.config, self.sim.cameras = self.config, self.named_cameras
            self.runner.reset(scenario)
        except (ScenarioError, ConfigError) as err:
            self.sim.config = previous  # the old scene keeps running
            response.success, response.message = False, str(err)
            return response
        self._was_colliding = False
        self._source = self.sim.source
        self._describe()
        response.success, response.message = True, f"reset to scenario {scenario.name!r}: {scenario.description}"
        return response

    # ------------------------------------------------------------------ publishing
    def publish(self, tick: Tick) -> None:
        """Publish what is due after one runner tick."""
        stamp = _stamp(tick.clock)
        state = self.sim.get_state()
        self._pub_clock.publish(Clock(clock=stamp))
        self._pub_joints.publish(q_to_joint_state(state.q, state.dq, stamp=stamp))
        self._pub_collision.publish(Bool(data=tick.collided))
        self._pub_distance.publish(Float64(data=self.sim.nearest_object()[0]))
        if tick.collided and not self._was_colliding:
            self.get_logger().info(f"arm touches the scene: {self.sim.contacts()}")
        self._was_colliding = tick.collided
        frame = self.config.frame_id
        for name in tick.clouds_due:
            pub_cloud, pub_pose = self._camera_publishers(name)
            pub_cloud.publish(xyz_to_cloud(self.sim.point_cloud(name), frame_id=frame, stamp=stamp))
            eye, orientation = self.sim.camera_pose(name)
            pub_pose.publish(target_to_pose_stamped(eye, orientation, frame_id=frame, stamp=stamp))
        if tick.cloud_due:
            target = self.sim.target_pose()
            if target is not None:
                self._pub_target.publish(target_to_pose_stamped(*target, frame_id=self.config.frame_id, stamp=stamp))
            self._check_warnings()

    def _check_warnings(self) -> None:
        for name, count in self.sim.warnings().items():
            if name not in self._warned:
                self._warned.add(name)
                self.get_logger().warning(f"MuJoCo warning {name} ({count} times since reset)")

    def close(self) -> None:
        self.sim.close()


def parse_args(argv: list[str]) -> argparse.Namespace:
    """The node's own arguments (ROS arguments already removed)."""
    parser = argparse.ArgumentParser(prog="sim", description="MuJoCo Panda simulator node")
    parser.add_argument("--record", type=Path, help="write pictures: out.gif, or a directory for PNG frames")
    parser.add_argument("--record-fps", type=float, default=10.0, help="pictures per simulated second")
    parser.add_argument("--record-size", default="480x360", help="picture size WIDTHxHEIGHT")
    parser.add_argument("--record-camera", default=OVERVIEW_CAMERA, choices=(OVERVIEW_CAMERA, DEPTH_CAMERA))
    parser.add_argument("--duration", type=float, default=0.0, help="stop after this many simulated seconds")
    args = parser.parse_args(argv)
    try:
        width, height = (int(v) for v in args.record_size.lower().split("x"))
    except ValueError:
        parser.error(f"--record-size: expected WIDTHxHEIGHT, got {args.record_size!r}")
    if not (8 <= width <= 1280 and 8 <= height <= 960) or args.record_fps <= 0:
        parser.error("--record-size must be within 1280x960 and --record-fps positive")
    args.record_width, args.record_height = width, height
    return args


def main() -> int:
    args = parse_args(remove_ros_args(sys.argv)[1:])
    rclpy.init(args=sys.argv)
    node = None
    recorder = snapshotter = None
    try:
        try:
            node = SimNode(frame_rate=args.record_fps if args.record else 0.0)
        except (ConfigError, ScenarioError) as err:
            get_logger("sim").error(f"cannot start: {err}")
            return 2
        executor = SingleThreadedExecutor()
        executor.add_node(node)
        if args.record:
            recorder = Recorder(args.record, fps=args.record_fps)
        while rclpy.ok():
            tick = node.runner.advance()
            node.publish(tick)
            if recorder is not None and tick.frame_due:
                if snapshotter is None or snapshotter.model is not node.sim.model:  # new scene after a reset
                    if snapshotter is not None:
                        snapshotter.close()
                    snapshotter = Snapshotter(node.sim.model, args.record_camera, args.record_width, args.record_height)
                recorder.add(snapshotter.render(node.sim.data))
            if args.duration > 0 and tick.clock >= args.duration:
                break
            lag = node.runner.wait(lambda timeout: executor.spin_once(timeout_sec=timeout))
            if lag > 0.1:
                node.get_logger().warning(
                    f"cannot keep the real-time factor (behind by {lag:.2f} s); simulated time slips",
                    throttle_duration_sec=10.0,
                )
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    except Exception:
        if rclpy.ok():  # a publish racing the Ctrl-C shutdown fails with an RCLError: not an error
            raise
    finally:
        if recorder is not None:
            path = recorder.close()
            print(f"wrote {recorder.count} pictures to {path}", file=sys.stderr)
        if node is not None:
            node.close()
            node.destroy_node()
        rclpy.try_shutdown()
    return 0


if __name__ == "__main__":
    sys.exit(main())

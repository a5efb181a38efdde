"""scene_encoder node: point clouds -> voxel scene embeddings for the learned collision backend.

Subscribes camera/points (sensor_msgs/PointCloud2, frame `world`, robot points removed) and camera/pose
(geometry_msgs/PoseStamped, frame `world`: the camera's optical centre, for a network with visibility
channels). For each cloud it drops NaN/inf points, crops to the encoder's workspace bounds, downsamples clouds
above max_points, encodes (with the newest camera origin if its stamp is within origin_max_age_s of the
cloud's, else with the origin unknown) and publishes scene_embedding (PointCloud2 of voxel centres with
float32 fields f0..fC-1, frame `world`, stamp of the input cloud). An empty cloud is encoded as an empty
scene (status WARN); a malformed one is refused (status ERROR, nothing published). ~/status
(diagnostic_msgs/DiagnosticArray) at status_rate_hz.
Parameters: SceneEncoderNodeConfig (config/scene_encoder.yaml), validated; a bad value is refused with a reason.

    python -m latent_planner_ros run scene_encoder [--ros-args --params-file config/scene_encoder.yaml]
"""

from __future__ import annotations

import sys
import time

import torch
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import PoseStamped
from rcl_interfaces.msg import ParameterDescriptor, SetParametersResult
from rclpy.node import Node
from sensor_msgs.msg import PointCloud2

from latent_planner_ros.models.checkpoint import CheckpointError
from latent_planner_ros.models.collision_io import load_scene_encoder
from latent_planner_ros.models.scene_encoder import SceneEncoder
from latent_planner_ros.nodes.node_main import run_node
from latent_planner_ros.nodes.scene_encoder_config import SceneEncoderNodeConfig
from latent_planner_ros.perception.camera_origin import CameraOrigin
from latent_planner_ros.perception.scene_input import SceneInputMonitor, prepare_cloud
from msg_adapters import AdapterError, cloud_to_xyz, embedding_to_cloud, pose_stamped_to_target, status_array
from sim_bridge.params import ConfigError, from_params, to_params

FRAME = "world"


def _load_encoder(checkpoint: str) -> SceneEncoder:
    """The scene encoder of a collision checkpoint (empty = shipped), in eval mode; raises CheckpointError."""
    return load_scene_encoder(checkpoint or None).eval()


class SceneEncoderNode(Node):
    def __init__(self):
        super().__init__("scene_encoder")
        self._param_names = to_params(SceneEncoderNodeConfig())
        for name, value in self._param_names.items():
            self.declare_parameter(name, value, ParameterDescriptor(dynamic_typing=True))
        params = {n: self.get_parameter(n).value for n in self._param_names}
        self.config = from_params(SceneEncoderNodeConfig, params)
        self.encoder = _load_encoder(self.config.checkpoint)
        self.monitor = SceneInputMonitor(self.config.stale_after_s)
        self.origin = CameraOrigin(self.config.origin_max_age_s)
        self.add_on_set_parameters_callback(self._on_set_parameters)

        self.pub_embedding = self.create_publisher(PointCloud2, "scene_embedding", 2)
        self.pub_status = self.create_publisher(DiagnosticArray, "~/status", 10)
        self.create_subscription(PointCloud2, "camera/points", self._on_cloud, 2)
        self.create_subscription(PoseStamped, "camera/pose", self._on_camera_pose, 10)
        self._status_timer = self.create_timer(1.0 / self.config.status_rate_hz, self._publish_status)
        enc = self.encoder.config
        self.get_logger().info(
            f"scene encoder ready: {self.config.checkpoint or 'shipped checkpoint'}, grid {enc.grid_shape} "
            f"of {enc.voxel_size} m voxels, {enc.channels} channels, bounds {enc.bounds_min}..{enc.bounds_max}"
        )

    def _now(self) -> float:
        return self.get_clock().now().nanoseconds * 1e-9

    # -- parameters ------------------------------------------------------------------------------
    def _on_set_parameters(self, params) -> SetParametersResult:
        ours = {p.name: p.value for p in params if p.name in self._param_names}  # not use_sim_time etc.
        try:
            config = from_params(SceneEncoderNodeConfig, ours, base=self.config)
            encoder = _load_encoder(config.checkpoint) if config.checkpoint != self.config.checkpoint else None
        except (ConfigError, CheckpointError) as err:
            return SetParametersResult(successful=False, reason=str(err))
        if encoder is not None:
            self.encoder = encoder
        if config.status_rate_hz != self.config.status_rate_hz:
            self._status_timer.cancel()
            self.destroy_timer(self._status_timer)
            self._status_timer = self.create_timer(1.0 / config.status_rate_hz, self._publish_status)
        self.monitor.stale_after_s = config.stale_after_s
        self.origin.max_age_s = config.origin_max_age_s
        self.config = config
        return SetParametersResult(successful=True)

    # -- clouds -------------------------------------------------------------------------------------
    def _refuse(self, msg: PointCloud2, reason: str) -> None:
        self.monitor.on_refused(self._now(), reason, int(msg.width) * int(msg.height))
        self.get_logger().warning(reason, throttle_duration_sec=2.0)

    def _on_camera_pose(self, msg: PoseStamped) -> None:
        try:
            pose = pose_stamped_to_target(msg, FRAME)
        except AdapterError as err:  # the previous origin stays; the reason is reported
            self.monitor.last_error = f"camera/pose refused: {err}"
            self.get_logger().warning(self.monitor.last_error, throttle_duration_sec=2.0)
            return
        self.origin.on_pose(pose.position, _seconds(msg.header.stamp))

    def _on_cloud(self, msg: PointCloud2) -> None:
        if msg.header.frame_id != FRAME:
            self._refuse(msg, f"camera/points refused: frame {msg.header.frame_id!r}, expected {FRAME!r}")
            return
        try:
            points = cloud_to_xyz(msg)
        except AdapterError as err:
            self._refuse(msg, f"camera/points refused: {err}")
            return
        t0 = time.perf_counter()
        enc, cfg = self.encoder.config, self.config
        n_in = int(msg.width) * int(msg.height)  # cloud_to_xyz already dropped NaN/inf points
        try:
            cloud = prepare_cloud(points, enc.bounds_min, enc.bounds_max, cfg.max_points, cfg.downsample_voxel, n_in)
            eye, origin = self.origin.for_cloud(_seconds(msg.header.stamp))
            if not self.encoder.config.visibility:
                eye, origin = None, "not used by this network"
            with torch.no_grad():
                centres, features = self.encoder.encode(cloud.points, eye).to_points()
            out = embedding_to_cloud(centres, features, frame_id=FRAME, stamp=msg.header.stamp)
        except (AdapterError, ValueError, RuntimeError) as err:  # never stop on one bad cloud
            self._refuse(msg, f"camera/points not encoded: {err}")
            return
        encode_ms = (time.perf_counter() - t0) * 1000.0
        self.pub_embedding.publish(out)
        self.monitor.on_encoded(self._now(), cloud, encode_ms, origin)

    def _publish_status(self) -> None:
        report = self.monitor.report(self._now())
        stamp = self.get_clock().now().to_msg()
        msg = status_array("scene_encoder", report.level, report.message, report.values, "scene_encoder", stamp)
        self.pub_status.publish(msg)


def _seconds(stamp) -> float:
    return stamp.sec + stamp.nanosec * 1e-9


def main() -> int:
    torch.set_num_threads(1)
    return run_node("scene_encoder", SceneEncoderNode, (CheckpointError, ConfigError))


if __name__ == "__main__":
    sys.exit(main())

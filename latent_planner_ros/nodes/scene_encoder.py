"""scene_encoder node: point clouds -> voxel scene embeddings for the learned collision backend.

Subscribes each topic of `cloud_topics` (sensor_msgs/PointCloud2 in `world`, the robot base frame or a frame of
`frames.extrinsics`, robot points removed; default camera/points) and, beside each, its camera's pose topic
(geometry_msgs/PoseStamped, same frames: the optical
centre, for a network with visibility channels; `camera/points` -> `camera/pose`). It keeps the newest cloud of
each topic and, once every camera that is not stale has delivered a new cloud (at once with one camera), fuses
them in the robot base frame with one camera origin per point (perception/cloud_fusion.py): a topic whose newest
cloud is stamped more than cloud_max_age_s from the newest one is left out and named on the status (WARN). It drops
NaN/inf points, crops to the encoder's workspace bounds, downsamples clouds above max_points (each camera's
points apart, so they keep their origin), encodes (each point with its camera's newest pose if stamped within
origin_max_age_s of its cloud, else with the origin unknown) and publishes scene_embedding (PointCloud2 of voxel
centres with float32 fields f0..fC-1, frame `<frames.joint_prefix>link0`, stamp of the cloud that completed the
round). An empty cloud is encoded as an empty scene (status WARN); a malformed cloud, or one in another frame, is
refused with the topic and the reason (status ERROR, logged, nothing published; the topic keeps its previous
cloud). ~/status and /diagnostics (diagnostic_msgs/DiagnosticArray) at status_rate_hz.
Parameters: SceneEncoderNodeConfig (config/scene_encoder.yaml), statically typed with descriptors
(latent_planner_ros/params/ros.py); a bad value is refused with its dotted name and the reason.

    python -m latent_planner_ros run scene_encoder [--ros-args --params-file config/scene_encoder.yaml]
"""

from __future__ import annotations

import sys
import time
from functools import partial

import numpy as np
import torch
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import PoseStamped
from rcl_interfaces.msg import SetParametersResult
from rclpy.node import Node
from sensor_msgs.msg import PointCloud2

from latent_planner_ros.models.checkpoint import CheckpointError
from latent_planner_ros.models.collision_io import load_scene_encoder
from latent_planner_ros.models.scene_encoder import SceneEncoder
from latent_planner_ros.nodes.node_main import run_node
from latent_planner_ros.nodes.qos import CloudSubscription
from latent_planner_ros.nodes.scene_encoder_config import RANGES, READ_ONLY, SceneEncoderNodeConfig
from latent_planner_ros.params.config import ConfigError, from_params
from latent_planner_ros.params.ros import ConfigParams
from latent_planner_ros.perception.cloud_fusion import CloudFusion, CloudRefused, pose_topic_of
from latent_planner_ros.perception.scene_input import SceneInputMonitor, prepare_cloud
from msg_adapters import AdapterError, cloud_to_xyz, embedding_to_cloud, pose_stamped_to_target, status_array


def _load_encoder(checkpoint: str) -> SceneEncoder:
    """The scene encoder of a collision checkpoint (empty = shipped), in eval mode; raises CheckpointError."""
    return load_scene_encoder(checkpoint or None).eval()


class SceneEncoderNode(Node):
    def __init__(self):
        super().__init__("scene_encoder")
        params = ConfigParams(self, SceneEncoderNodeConfig, ranges=RANGES, read_only=READ_ONLY)
        self.config = params.config
        self.encoder = _load_encoder(self.config.checkpoint)
        cfg = self.config
        self.monitor = SceneInputMonitor(cfg.stale_after_s, ", ".join(cfg.cloud_topics))
        self.fusion = CloudFusion(cfg.cloud_topics, cfg.frames.frames(), cfg.cloud_max_age_s, cfg.origin_max_age_s)
        params.on_set(self._on_set_parameters)

        self.pub_embedding = self.create_publisher(PointCloud2, "scene_embedding", 2)
        self.pub_status = self.create_publisher(DiagnosticArray, "~/status", 10)
        self.pub_diagnostics = self.create_publisher(DiagnosticArray, "/diagnostics", 10)
        self.cloud_subscriptions = [  # one per topic, its publishers' reliability (nodes/qos.py)
            CloudSubscription(self, cloud_topic, partial(self._on_cloud, cloud_topic))
            for cloud_topic in cfg.cloud_topics
        ]
        for cloud_topic in cfg.cloud_topics:
            pose_topic = pose_topic_of(cloud_topic)
            self.create_subscription(PoseStamped, pose_topic, partial(self._on_camera_pose, cloud_topic), 10)
        self._status_timer = self.create_timer(1.0 / self.config.status_rate_hz, self._publish_status)
        enc = self.encoder.config
        self.get_logger().info(
            f"scene encoder ready: {self.config.checkpoint or 'shipped checkpoint'}, grid {enc.grid_shape} "
            f"of {enc.voxel_size} m voxels, {enc.channels} channels, bounds {enc.bounds_min}..{enc.bounds_max}; "
            f"clouds from {', '.join(cfg.cloud_topics)}"
        )

    def _now(self) -> float:
        return self.get_clock().now().nanoseconds * 1e-9

    # -- parameters ------------------------------------------------------------------------------
    def _on_set_parameters(self, ours: dict) -> SetParametersResult:
        """Apply {dotted name: value} of our parameters (read-only ones never get here, nor use_sim_time)."""
        try:
            config = from_params(SceneEncoderNodeConfig, ours, base=self.config)
            encoder = _load_encoder(config.checkpoint) if config.checkpoint != self.config.checkpoint else None
        except ConfigError as err:
            return SetParametersResult(successful=False, reason=str(err))
        except CheckpointError as err:
            return SetParametersResult(successful=False, reason=f"checkpoint: {err}")
        if encoder is not None:
            self.encoder = encoder
        if config.status_rate_hz != self.config.status_rate_hz:
            self._status_timer.cancel()
            self.destroy_timer(self._status_timer)
            self._status_timer = self.create_timer(1.0 / config.status_rate_hz, self._publish_status)
        self.monitor.stale_after_s = config.stale_after_s
        self.fusion.set_origin_max_age(config.origin_max_age_s)
        self.fusion.max_age_s = config.cloud_max_age_s
        self.config = config
        return SetParametersResult(successful=True)

    # -- clouds -------------------------------------------------------------------------------------
    def _refuse(self, msg: PointCloud2, reason: str) -> None:
        self.monitor.on_refused(self._now(), reason, int(msg.width) * int(msg.height))
        self.get_logger().warning(reason, throttle_duration_sec=2.0)

    def _on_camera_pose(self, cloud_topic: str, msg: PoseStamped) -> None:
        try:
            pose = pose_stamped_to_target(msg, expected_frame=None)  # the fusion moves it into the base frame
            self.fusion.add_pose(cloud_topic, pose.position, msg.header.frame_id, _seconds(msg.header.stamp))
        except (AdapterError, CloudRefused) as err:  # the previous origin stays; the reason is reported
            text = str(err) if isinstance(err, CloudRefused) else f"{pose_topic_of(cloud_topic)} refused: {err}"
            self.monitor.last_error = text
            self.get_logger().warning(text, throttle_duration_sec=2.0)

    def _on_cloud(self, cloud_topic: str, msg: PointCloud2) -> None:
        try:
            self.fusion.check(cloud_topic, msg.header.frame_id)
            points = cloud_to_xyz(msg)
            n_in = int(msg.width) * int(msg.height)  # cloud_to_xyz already dropped NaN/inf points
            self.fusion.add_cloud(cloud_topic, points, msg.header.frame_id, _seconds(msg.header.stamp), n_in)
        except CloudRefused as err:
            self._refuse(msg, str(err))
            return
        except AdapterError as err:
            self._refuse(msg, f"{cloud_topic} refused: {err}")
            return
        if self.fusion.round_complete():
            self._encode(msg.header.stamp)

    def _encode(self, stamp) -> None:
        """Fuse the newest clouds, encode them and publish the embedding with `stamp`."""
        t0 = time.perf_counter()
        fused = self.fusion.fuse()
        enc, cfg = self.encoder.config, self.config
        n_in = sum(self.fusion.received[t] for t in fused.sources)
        origin = fused.origin_summary()
        origins = fused.origins if enc.visibility and np.isfinite(fused.origins).any() else None
        if not enc.visibility:
            origin = "not used by this network"
        try:
            cloud = prepare_cloud(fused.points, enc.bounds_min, enc.bounds_max, cfg.max_points, cfg.downsample_voxel,
                                  n_in, origins)  # fmt: skip
            with torch.no_grad():
                centres, features = self.encoder.encode(cloud.points, cloud.origins).to_points()
            out = embedding_to_cloud(centres, features, frame_id=self.fusion.frame_id, stamp=stamp)
        except (AdapterError, ValueError, RuntimeError) as err:  # never stop on one bad cloud
            reason = f"{', '.join(fused.sources)} not encoded: {err}"
            self.monitor.on_refused(self._now(), reason, n_in)
            self.get_logger().warning(reason, throttle_duration_sec=2.0)
            return
        encode_ms = (time.perf_counter() - t0) * 1000.0
        self.pub_embedding.publish(out)
        stale = ", ".join(f"{t} ({gap:.2f} s behind)" for t, gap in fused.stale.items())
        sources = ", ".join(f"{t} ({n})" for t, n in zip(fused.sources, fused.counts, strict=True))
        self.monitor.on_encoded(self._now(), cloud, encode_ms, origin, sources, stale)
        if stale:
            self.get_logger().warning(f"clouds left out as stale: {stale}", throttle_duration_sec=5.0)

    def _publish_status(self) -> None:
        report = self.monitor.report(self._now())
        stamp = self.get_clock().now().to_msg()
        msg = status_array("scene_encoder", report.level, report.message, report.values, "scene_encoder", stamp)
        self.pub_status.publish(msg)
        self.pub_diagnostics.publish(msg)


def _seconds(stamp) -> float:
    return stamp.sec + stamp.nanosec * 1e-9


def main() -> int:
    torch.set_num_threads(1)
    return run_node("scene_encoder", SceneEncoderNode, (CheckpointError, ConfigError))


if __name__ == "__main__":
    sys.exit(main())

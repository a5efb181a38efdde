"""A depth camera that publishes its clouds BEST_EFFORT (the sensor-data profile of most camera drivers) reaches
every node that takes clouds; so does a RELIABLE one (the sim)."""

from __future__ import annotations

import time

import numpy as np
import pytest
import rclpy
from rclpy.executors import SingleThreadedExecutor
from rclpy.qos import QoSProfile, ReliabilityPolicy, qos_profile_sensor_data
from sensor_msgs.msg import PointCloud2

from msg_adapters import xyz_to_cloud

pytestmark = pytest.mark.ros

RELIABLE = QoSProfile(depth=2, reliability=ReliabilityPolicy.RELIABLE)


def _planner():
    from latent_planner_ros.nodes.planner import PlannerNode

    return PlannerNode()


def _ompl_planner():
    from latent_planner_ros.nodes.ompl_planner import OmplPlannerNode

    return OmplPlannerNode()


def _scene_encoder():
    from latent_planner_ros.nodes.scene_encoder import SceneEncoderNode

    return SceneEncoderNode()


@pytest.mark.parametrize("factory", [_planner, _ompl_planner, _scene_encoder], ids=lambda f: f.__name__[1:])
@pytest.mark.parametrize("qos", [qos_profile_sensor_data, RELIABLE], ids=["best_effort", "reliable"])
def test_clouds_of_a_best_effort_or_reliable_camera_are_taken(factory, qos):
    rclpy.init(args=["--ros-args", "-p", "amp_ls.collision_backend:=geometric"] if factory is _planner else None)
    node = factory()
    camera = rclpy.create_node("camera_driver")
    executor = SingleThreadedExecutor()
    executor.add_node(node)
    executor.add_node(camera)
    try:
        pub = camera.create_publisher(PointCloud2, "camera/points", qos)
        points = np.random.default_rng(0).uniform([0.3, -0.3, 0.0], [0.7, 0.3, 0.4], (500, 3)).astype(np.float32)
        end = time.monotonic() + 10.0
        while pub.get_subscription_count() < 1 and time.monotonic() < end:
            executor.spin_once(timeout_sec=0.05)
        # the node subscribes with the camera's reliability once it sees the publisher (nodes/qos.py)
        end = time.monotonic() + 10.0
        while time.monotonic() < end and not node.cloud_subscriptions[0].profiles:
            executor.spin_once(timeout_sec=0.05)
        assert [p.reliability for p in node.cloud_subscriptions[0].profiles] == [qos.reliability]
        kind = "reliable" if qos.reliability == ReliabilityPolicy.RELIABLE else "best effort"
        assert node.cloud_subscriptions[0].describe() == f"camera/points: {kind}"
        assert pub.get_subscription_count() == 1
        end = time.monotonic() + 10.0
        while not node.fusion.received and time.monotonic() < end:
            stamp = node.get_clock().now().to_msg()
            pub.publish(xyz_to_cloud(points, frame_id="world", stamp=stamp))
            for _ in range(5):
                executor.spin_once(timeout_sec=0.02)
        assert node.fusion.received.get("camera/points") == 500
    finally:
        executor.shutdown()
        camera.destroy_node()
        node.destroy_node()
        rclpy.shutdown()


def test_the_profile_follows_the_publishers():
    """RELIABLE only when every publisher is RELIABLE (its large clouds then arrive whole); BEST_EFFORT otherwise,
    and before any publisher is seen (it matches both kinds)."""
    from latent_planner_ros.nodes.qos import CLOUD_QOS, RELIABLE_CLOUD_QOS, profile_for

    best, reliable = ReliabilityPolicy.BEST_EFFORT, ReliabilityPolicy.RELIABLE
    assert profile_for([]) is CLOUD_QOS
    assert profile_for([reliable]) is RELIABLE_CLOUD_QOS
    assert profile_for([reliable, reliable]) is RELIABLE_CLOUD_QOS
    assert profile_for([reliable, best]) is CLOUD_QOS
    assert profile_for([best]) is CLOUD_QOS
    assert CLOUD_QOS.reliability == best and RELIABLE_CLOUD_QOS.reliability == reliable


def test_each_cloud_message_is_passed_on_once():
    """With a second subscription (publishers of both kinds on one topic), a RELIABLE publisher's message arrives
    through both: the second copy is dropped, in either order; the same content sent again later (a static scene,
    stamp 0) is passed on again."""
    from latent_planner_ros.nodes.qos import DUPLICATE_WINDOW_S, Deduplicated

    taken = []
    d = Deduplicated(taken.append)
    a = xyz_to_cloud(np.zeros((10, 3), dtype=np.float32))
    b = xyz_to_cloud(np.ones((12, 3), dtype=np.float32))
    d.reliable(a)
    d.best_effort(a)  # its copy
    d.best_effort(b)  # a new message first through the other subscription
    d.reliable(b)  # its copy
    assert taken == [a, b]
    time.sleep(DUPLICATE_WINDOW_S + 0.01)
    d.best_effort(b)  # the same cloud published again later
    assert taken == [a, b, b]

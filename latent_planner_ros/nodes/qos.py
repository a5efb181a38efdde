"""QoS of the suite's point-cloud subscriptions: one subscription per cloud topic, with its publishers' reliability.

Depth cameras publish their clouds with the sensor-data profile (BEST_EFFORT, as realsense2_camera and most
drivers do) or RELIABLE (the sim). A BEST_EFFORT subscription matches both, a RELIABLE one only the latter; but a
BEST_EFFORT subscription loses a large cloud from a RELIABLE publisher whenever one of its many fragments is lost
(a 2-million-point cloud, 24 MB, never arrived here). So each node's `CloudSubscription` asks the graph which
publishers the topic has (as rosbag2's adaptive QoS does) and subscribes RELIABLE when every publisher offers
RELIABLE, BEST_EFFORT otherwise (before any publisher is seen, too); it looks again every second and re-subscribes
when that changes. Only the newest cloud is used, so the depth stays small. Other topics keep the default profile
(RELIABLE, VOLATILE, depth 10), execution_owner and robot_description are TRANSIENT_LOCAL (nodes/execution_owner.py,
nodes/robot_info.py).
"""

from __future__ import annotations

from collections.abc import Callable

from rclpy.clock import Clock, ClockType
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import PointCloud2

CLOUD_QOS = QoSProfile(
    history=HistoryPolicy.KEEP_LAST,
    depth=2,
    reliability=ReliabilityPolicy.BEST_EFFORT,
    durability=DurabilityPolicy.VOLATILE,
)
"""Cloud subscriptions with a BEST_EFFORT publisher (or none yet): sensor data (BEST_EFFORT, VOLATILE), the two
newest kept."""

RELIABLE_CLOUD_QOS = QoSProfile(
    history=HistoryPolicy.KEEP_LAST,
    depth=2,
    reliability=ReliabilityPolicy.RELIABLE,
    durability=DurabilityPolicy.VOLATILE,
)
"""Cloud subscriptions whose publishers are all RELIABLE: their large clouds arrive whole."""

GRAPH_PERIOD_S = 1.0
"""[s] (steady time) how often a CloudSubscription looks at the topic's publishers"""


def profile_for(reliabilities: list) -> QoSProfile:
    """The subscription profile for publishers of these ReliabilityPolicy values: RELIABLE when there is at least
    one and every one is RELIABLE, else the sensor-data profile (it matches every publisher)."""
    if reliabilities and all(r == ReliabilityPolicy.RELIABLE for r in reliabilities):
        return RELIABLE_CLOUD_QOS
    return CLOUD_QOS


class CloudSubscription:
    """A PointCloud2 subscription to `topic` on `node` whose reliability follows the topic's publishers.

    Args:
        node: the subscribing node (its executor runs the graph check, on a steady-time timer).
        topic: the cloud topic (relative names are resolved as the node resolves them).
        callback: called with each PointCloud2.
    """

    def __init__(self, node: Node, topic: str, callback: Callable[[PointCloud2], None]):
        self.node, self.topic, self.callback = node, topic, callback
        self.profile: QoSProfile | None = None
        self.subscription = None
        self.update()
        self._timer = node.create_timer(GRAPH_PERIOD_S, self.update, clock=Clock(clock_type=ClockType.STEADY_TIME))

    def describe(self) -> str:
        """The profile subscribed with now: "<topic>: reliable" or "<topic>: best effort"."""
        reliable = self.profile is not None and self.profile.reliability == ReliabilityPolicy.RELIABLE
        return f"{self.topic}: {'reliable' if reliable else 'best effort'}"

    def update(self) -> None:
        """Subscribe (again) if the topic's publishers call for another profile than the current one."""
        infos = self.node.get_publishers_info_by_topic(self.node.resolve_topic_name(self.topic))
        wanted = profile_for([info.qos_profile.reliability for info in infos])
        if wanted is self.profile:
            return
        if self.subscription is not None:
            self.node.destroy_subscription(self.subscription)
        self.subscription = self.node.create_subscription(PointCloud2, self.topic, self.callback, wanted)
        self.profile = wanted

"""QoS of the suite's point-cloud subscriptions: one subscription per cloud topic, with its publishers' reliability.

Depth cameras publish their clouds with the sensor-data profile (BEST_EFFORT, as realsense2_camera and most
drivers do) or RELIABLE (the sim). A BEST_EFFORT subscription matches both, a RELIABLE one only the latter; but a
BEST_EFFORT subscription loses a large cloud from a RELIABLE publisher whenever one of its many fragments is lost
(a 2-million-point cloud, 24 MB, never arrived here). So each node's `CloudSubscription` asks the graph which
publishers the topic has (as rosbag2's adaptive QoS does) and subscribes RELIABLE when every publisher offers
RELIABLE, BEST_EFFORT otherwise; it looks every second, and adds a subscription with the other profile (each
message passed on once) if publishers appear that the first one does not serve. Only the newest cloud is used, so
the depth stays small. Other topics keep the default profile (RELIABLE, VOLATILE, depth 10), execution_owner and
robot_description are TRANSIENT_LOCAL (nodes/execution_owner.py, nodes/robot_info.py).
"""

from __future__ import annotations

import time
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
"""Cloud subscriptions with a BEST_EFFORT publisher: sensor data (BEST_EFFORT, VOLATILE), the two newest kept."""

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
    """PointCloud2 subscriptions to `topic` on `node` with the reliability of the topic's publishers.

    No subscription exists until a publisher is seen; then one with the profile its publishers call for (see
    `profile_for`). Should publishers appear later that the subscription does not serve (a BEST_EFFORT camera on a
    topic subscribed RELIABLE, or the other way round), a second subscription with the other profile is added and
    each message is passed on once (`Deduplicated`). Subscriptions are never destroyed while the node runs: an
    rclpy executor can still hold a destroyed subscription among the entities it is about to take from.

    Args:
        node: the subscribing node (its executor runs the graph check, on a steady-time timer).
        topic: the cloud topic (relative names are resolved as the node resolves them).
        callback: called with each PointCloud2.
    """

    def __init__(self, node: Node, topic: str, callback: Callable[[PointCloud2], None]):
        self.node, self.topic = node, topic
        self.deduplicated = Deduplicated(callback)
        self.profiles: list[QoSProfile] = []
        self.subscriptions: list = []
        self.update()
        self._timer = node.create_timer(GRAPH_PERIOD_S, self.update, clock=Clock(clock_type=ClockType.STEADY_TIME))

    def describe(self) -> str:
        """How the topic is subscribed: "<topic>: reliable", "<topic>: best effort", both, or no publisher yet."""
        if not self.profiles:
            return f"{self.topic}: no publisher yet"
        kinds = ["reliable" if p.reliability == ReliabilityPolicy.RELIABLE else "best effort" for p in self.profiles]
        return f"{self.topic}: {' + '.join(kinds)}"

    def update(self) -> None:
        """Subscribe with the profile the topic's publishers call for, unless a subscription with it exists."""
        infos = self.node.get_publishers_info_by_topic(self.node.resolve_topic_name(self.topic))
        if not infos:
            return
        wanted = profile_for([info.qos_profile.reliability for info in infos])
        if any(p is wanted for p in self.profiles):
            return
        callback = self.deduplicated.reliable if wanted is RELIABLE_CLOUD_QOS else self.deduplicated.best_effort
        self.subscriptions.append(self.node.create_subscription(PointCloud2, self.topic, callback, wanted))
        self.profiles.append(wanted)


DUPLICATE_WINDOW_S = 0.02
"""[s] a message with the same stamp and size as the last one passed on, arriving through the other subscription
within this time, is that message's second copy"""


class Deduplicated:
    """`callback(msg)` once per cloud message received through the two subscriptions of one topic (`reliable`,
    `best_effort`): the second copy of a message a RELIABLE publisher sent to both is dropped (same stamp and
    size, through the other subscription, within DUPLICATE_WINDOW_S)."""

    def __init__(self, callback: Callable):
        self.callback = callback
        self._last: tuple | None = None  # (key, subscription, monotonic time) of the last message passed on

    def _take(self, which: str, msg) -> None:
        key = (msg.header.stamp.sec, msg.header.stamp.nanosec, msg.width, msg.height, len(msg.data))
        now = time.monotonic()
        last = self._last
        if last is not None and last[0] == key and last[1] != which and now - last[2] < DUPLICATE_WINDOW_S:
            return
        self._last = (key, which, now)
        self.callback(msg)

    def reliable(self, msg) -> None:
        self._take("reliable", msg)

    def best_effort(self, msg) -> None:
        self._take("best_effort", msg)

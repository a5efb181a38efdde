"""QoS of the suite's point-cloud subscriptions.

Depth cameras publish their clouds with the sensor-data profile (BEST_EFFORT, as realsense2_camera and most
drivers do) or RELIABLE (the sim). A BEST_EFFORT subscription matches both, a RELIABLE one only the latter; but a
BEST_EFFORT subscription loses a large cloud from a RELIABLE publisher whenever one of its many fragments is lost
(a 2-million-point cloud, 24 MB, never arrived here). So every node subscribes to each cloud topic twice, as sensor
data and as RELIABLE, and `Deduplicated` passes each message on once: a RELIABLE camera's clouds come through the
RELIABLE subscription whatever their size, a BEST_EFFORT camera's through the other. Only the newest cloud is
used, so the depth stays small. Other topics keep the default profile (RELIABLE, VOLATILE, depth 10),
execution_owner and robot_description are TRANSIENT_LOCAL (nodes/execution_owner.py, nodes/robot_info.py).
"""

from __future__ import annotations

import time
from collections.abc import Callable

from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

CLOUD_QOS = QoSProfile(
    history=HistoryPolicy.KEEP_LAST,
    depth=2,
    reliability=ReliabilityPolicy.BEST_EFFORT,
    durability=DurabilityPolicy.VOLATILE,
)
"""Subscriptions to camera clouds: sensor data (BEST_EFFORT, VOLATILE), the two newest kept."""

RELIABLE_CLOUD_QOS = QoSProfile(
    history=HistoryPolicy.KEEP_LAST,
    depth=2,
    reliability=ReliabilityPolicy.RELIABLE,
    durability=DurabilityPolicy.VOLATILE,
)
"""The second subscription to each cloud topic: RELIABLE, for RELIABLE publishers' large clouds."""

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

"""QoS of the suite's point-cloud subscriptions.

Depth cameras publish their clouds with the sensor-data profile (BEST_EFFORT, as realsense2_camera and most
drivers do) or RELIABLE (the sim). A BEST_EFFORT subscription matches both, a RELIABLE one only the latter, so
every node subscribes to clouds as sensor data; only the newest cloud is used, so the depth stays small. Other
topics keep the default profile (RELIABLE, VOLATILE, depth 10), execution_owner and robot_description are
TRANSIENT_LOCAL (nodes/execution_owner.py, nodes/robot_info.py).
"""

from __future__ import annotations

from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

CLOUD_QOS = QoSProfile(
    history=HistoryPolicy.KEEP_LAST,
    depth=2,
    reliability=ReliabilityPolicy.BEST_EFFORT,
    durability=DurabilityPolicy.VOLATILE,
)
"""Subscriptions to camera clouds: sensor data (BEST_EFFORT, VOLATILE), the two newest kept."""

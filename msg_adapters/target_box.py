"""visualization_msgs/Marker (CUBE) <-> a caller's box around a grasp target.

A grasp goal's target is found in the cloud, or given by the caller: a radius (a parameter of the planner nodes)
or a box, published as one CUBE marker on the nodes' `grasp_target` topic: pose = the box's centre and
orientation (its frame any frame the nodes accept for goals), scale = its full edge lengths [m]. The box stays
until replaced or cleared (DELETE or DELETEALL); `lifetime`, `ns` and `id` are ignored.
"""

from __future__ import annotations

import math

import numpy as np
from geometry_msgs.msg import PoseStamped
from visualization_msgs.msg import Marker

from msg_adapters.errors import AdapterError

MAX_EDGE_M = 2.0
"""[m] longest edge of a target box (a larger box would set aside most of a workcell)"""


def marker_to_box(msg: Marker) -> tuple[PoseStamped, np.ndarray] | None:
    """(pose, half extents (3,) [m]) of a CUBE marker added or modified, or None for DELETE / DELETEALL (the
    caller clears its box). The pose keeps the marker's header; the caller transforms it into its base frame
    (msg_adapters.pose.pose_stamped_in_base), which refuses NaN poses and unknown frames.

    Raises:
        AdapterError: another marker type or action, or an edge that is not a finite length in (0, MAX_EDGE_M].
    """
    if msg.action in (Marker.DELETE, Marker.DELETEALL):
        return None
    if msg.action != Marker.ADD:
        raise AdapterError(f"grasp target marker action {msg.action} is not ADD, DELETE or DELETEALL")
    if msg.type != Marker.CUBE:
        raise AdapterError(f"grasp target marker type {msg.type} is not CUBE ({Marker.CUBE})")
    edges = [msg.scale.x, msg.scale.y, msg.scale.z]
    if not all(math.isfinite(e) and 0.0 < e <= MAX_EDGE_M for e in edges):
        raise AdapterError(f"grasp target box edges must be lengths in (0, {MAX_EDGE_M:g}] m, got {edges}")
    pose = PoseStamped()
    pose.header = msg.header
    pose.pose = msg.pose
    return pose, 0.5 * np.asarray(edges, dtype=float)


def box_to_marker(
    position: np.ndarray, quaternion_xyzw: np.ndarray, half_extents: np.ndarray, frame_id: str = "world"
) -> Marker:
    """A CUBE marker of a box: centre (3,) [m], orientation (4,) (x, y, z, w), half extents (3,) [m]."""
    msg = Marker()
    msg.header.frame_id = frame_id
    msg.type, msg.action = Marker.CUBE, Marker.ADD
    msg.pose.position.x, msg.pose.position.y, msg.pose.position.z = (float(v) for v in position)
    o = msg.pose.orientation
    o.x, o.y, o.z, o.w = (float(v) for v in quaternion_xyzw)
    msg.scale.x, msg.scale.y, msg.scale.z = (2.0 * float(v) for v in half_extents)
    msg.color.r, msg.color.g, msg.color.a = 0.2, 0.8, 0.5
    return msg

"""RViz markers for a planned end-effector path and its goal."""

from __future__ import annotations

import numpy as np
from geometry_msgs.msg import Point
from visualization_msgs.msg import Marker, MarkerArray


def path_markers(ee_positions: np.ndarray, goal_position: np.ndarray, stamp, frame_id: str = "world") -> MarkerArray:
    """A LINE_STRIP through ee_positions (T, 3) [m] and a SPHERE at goal_position (3,) [m]."""
    line = Marker(ns="planned_path", id=0, type=Marker.LINE_STRIP, action=Marker.ADD)
    line.header.frame_id, line.header.stamp = frame_id, stamp
    line.scale.x = 0.005
    line.color.g, line.color.a = 0.8, 1.0
    line.pose.orientation.w = 1.0
    line.points = [Point(x=float(p[0]), y=float(p[1]), z=float(p[2])) for p in ee_positions]
    goal = Marker(ns="goal", id=1, type=Marker.SPHERE, action=Marker.ADD)
    goal.header.frame_id, goal.header.stamp = frame_id, stamp
    goal.pose.position = Point(x=float(goal_position[0]), y=float(goal_position[1]), z=float(goal_position[2]))
    goal.pose.orientation.w = 1.0
    goal.scale.x = goal.scale.y = goal.scale.z = 0.03
    goal.color.r, goal.color.a = 1.0, 0.8
    return MarkerArray(markers=[line, goal])

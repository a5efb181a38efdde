"""Regression tests of what the fuzzing found, one per finding (named in the docstring)."""

from __future__ import annotations

import numpy as np
import pytest
from geometry_msgs.msg import PoseStamped
from visualization_msgs.msg import Marker, MarkerArray

from msg_adapters import AdapterError, apply_marker_array, pose_stamped_to_target


def _cylinder(**orientation) -> MarkerArray:
    m = Marker(type=Marker.CYLINDER, action=Marker.ADD)
    m.header.frame_id = "world"
    m.scale.x = m.scale.y = 0.1
    m.scale.z, m.pose.position.z = 0.2, 0.1
    for k, v in orientation.items():
        setattr(m.pose.orientation, k, v)
    return MarkerArray(markers=[m])


def test_a_cylinder_marker_with_a_huge_quaternion_is_read_not_overflowed():
    """Finding: apply_marker_array raised OverflowError (1e200 ** 2) for a marker quaternion with huge components;
    the planner's obstacles callback let it escape. A huge quaternion is a valid direction."""
    update = apply_marker_array(_cylinder(w=1e200))
    assert np.allclose(update.cylinders[("", 0)], [0.0, 0.0, 0.2, 0.05])
    with pytest.raises(AdapterError, match="tilted 90.0 deg"):
        apply_marker_array(_cylinder(x=1e300, w=1e300))


def test_a_pose_with_a_huge_quaternion_is_normalised():
    """Finding: pose_stamped_to_target raised ValueError from quat_to_matrix for components like 1.3e154 (their
    squared norm overflowed, the quaternion became zero); the scene encoder's camera pose callback let it escape."""
    msg = PoseStamped()
    msg.header.frame_id = "world"
    msg.pose.orientation.w = 1.3407807929942597e154
    target = pose_stamped_to_target(msg)
    assert np.allclose(target.quaternion_xyzw, [0, 0, 0, 1]) and np.allclose(target.rotation, np.eye(3))
    msg.pose.orientation.x, msg.pose.orientation.w = 1e308, 1e308
    assert np.allclose(pose_stamped_to_target(msg).quaternion_xyzw, [2**-0.5, 0, 0, 2**-0.5])
    msg.pose.orientation.x, msg.pose.orientation.w = 1e-12, 0.0
    with pytest.raises(AdapterError, match="zero norm"):
        pose_stamped_to_target(msg)

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


@pytest.mark.ros
def test_the_planner_drops_far_outliers_of_a_cloud():
    """Finding: a cloud with a finite outlier at 3e38 m made the planner's tick raise (IndexError / "array is too
    big" from the collision check's occupancy grid), which would stop the node; points beyond FAR_M are dropped."""
    import rclpy

    from latent_planner_ros.evaluation.fault_inputs import box_cloud
    from latent_planner_ros.nodes.planner import FAR_M, PlannerNode
    from msg_adapters import cloud_to_xyz, xyz_to_cloud

    box = cloud_to_xyz(box_cloud())
    rclpy.init()
    node = PlannerNode()
    try:
        for outlier in ([3e38, 0.0, 0.0], [0.5, -3e38, 1e30], [FAR_M * 2, 0.0, 0.0]):
            node._on_cloud("camera/points", xyz_to_cloud(np.vstack([box, [outlier]]).astype(np.float32)))
            node._on_tick()
            assert node._cloud_points == (len(box) + 1, len(box))
            assert np.abs(node.modes.amp_ls.cloud).max() < 1.0
    finally:
        node.destroy_node()
        rclpy.shutdown()


def test_a_scenario_path_of_an_unknown_users_home_is_refused_with_a_reason():
    """bench fuzz (sim.reset, sim.parameters): "~someone/x" raised RuntimeError from Path.expanduser."""
    from sim_bridge.scenario import ScenarioError
    from sim_bridge.scenario_files import find_scenario_file

    with pytest.raises(ScenarioError, match="~no_such_user_xyz/scene.yaml"):
        find_scenario_file("~no_such_user_xyz/scene.yaml")

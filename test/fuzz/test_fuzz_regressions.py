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


@pytest.mark.ros
def test_a_vanishing_rate_is_refused_and_the_status_timer_survives():
    """bench fuzz (scene_encoder.parameters, 1000 inputs): status_rate_hz = 1e-320 passed "> 0", its timer's period
    was infinite (OverflowError) after the old timer was destroyed, and every later change raised InvalidHandle.
    Rates now start at MIN_RATE_HZ, in every node that takes one."""
    import rclpy
    from rclpy.parameter import Parameter

    from latent_planner_ros.nodes.ompl_planner_config import OmplPlannerNodeConfig
    from latent_planner_ros.nodes.planner_config import PlannerNodeConfig
    from latent_planner_ros.nodes.scene_encoder import SceneEncoderNode
    from latent_planner_ros.params.config import MIN_RATE_HZ, ConfigError, from_params

    for cls, name in ((OmplPlannerNodeConfig, "status_rate_hz"), (PlannerNodeConfig, "status_rate_hz"),
                      (PlannerNodeConfig, "closed_loop.rate_hz")):  # fmt: skip
        with pytest.raises(ConfigError, match=name.split(".")[-1]):
            from_params(cls, {name: 1e-320})
        from_params(cls, {name: MIN_RATE_HZ})
    rclpy.init()
    node = SceneEncoderNode()
    try:
        r = node.set_parameters([Parameter("status_rate_hz", value=1e-320)])[0]
        assert not r.successful and "status_rate_hz" in r.reason
        assert node.set_parameters([Parameter("status_rate_hz", value=5.0)])[0].successful
        assert node._status_timer.timer_period_ns == 200_000_000
    finally:
        node.destroy_node()
        rclpy.shutdown()


def test_vanishing_check_steps_are_refused():
    """bench fuzz (ompl_planner.parameters, 1000 inputs): ompl.check_step_deg = 1.7e-140 passed "> 0" and OMPL
    raised RuntimeError on the resolution; AMP-LS's check_step_rad of 1e-12 would densify a step into ~1e12 states."""
    from latent_planner_ros.planning.amp_ls.config import MIN_CHECK_STEP_RAD, CheckConfig
    from latent_planner_ros.planning.ompl_baseline_config import MIN_CHECK_STEP_DEG, OmplConfig

    with pytest.raises(ValueError, match="check_step_deg must be >= 0.01"):
        OmplConfig(check_step_deg=1.7204630602674179e-140)
    assert OmplConfig(check_step_deg=MIN_CHECK_STEP_DEG).check_step_deg == MIN_CHECK_STEP_DEG
    with pytest.raises(ValueError, match="check_step_rad must be 0 or in"):
        CheckConfig(check_step_rad=1e-12)
    assert CheckConfig(check_step_rad=MIN_CHECK_STEP_RAD).check_step_rad == MIN_CHECK_STEP_RAD
    assert CheckConfig(check_step_rad=0.0).check_step_rad == 0.0  # the seed's fixed interp_steps


def test_a_checkpoint_path_with_no_file_name_is_refused_as_a_checkpoint_error():
    """bench fuzz (scene_encoder.parameters, 10,000 inputs): checkpoint = '.' raised ValueError from
    Path.with_suffix, which the parameter callback does not expect from a checkpoint."""
    from latent_planner_ros.models.checkpoint import CheckpointError, load_checkpoint

    for stem in (".", "/", ""):
        with pytest.raises(CheckpointError, match="names no file|checkpoint file missing"):
            load_checkpoint(stem)


@pytest.mark.parametrize("position", [[-1e308, 0.0, -1e7], [1e308, 1e308, 1e308], [0.3, 1e200, 0.4]])
def test_ik_towards_an_absurd_goal_gives_up_instead_of_raising(position):
    """bench fuzz (ompl_planner.plan and plan_grasp, 10,000 inputs): a goal at x = -1e308 m made the IK's
    error and Jacobian non-finite and numpy raised LinAlgError (singular matrix) out of the plan service."""
    from latent_planner_ros.planning.goal import Goal
    from latent_planner_ros.planning.ik import IkConfig, solve_ik
    from latent_planner_ros.robot.limits import Q_READY
    from latent_planner_ros.robot.panda import load_panda

    with np.errstate(all="ignore"):
        sol = solve_ik(load_panda(), Goal(np.array(position), np.eye(3), 0.01, 0.26), Q_READY, IkConfig())
    assert not sol.converged and np.all(np.isfinite(sol.q))

"""Parameters as ROS users expect them, and the frames every node accepts (ompl_planner in-process; the shared
pieces without ROS)."""

from __future__ import annotations

import numpy as np
import pytest
import rclpy
from rclpy.parameter import Parameter
from sensor_msgs.msg import JointState

from latent_planner_ros.nodes.frames_config import FramesConfig
from latent_planner_ros.params.ros import undeclared_overrides
from latent_planner_ros.perception.cloud_fusion import CloudFusion, CloudRefused
from msg_adapters import AdapterError, target_to_pose_stamped, xyz_to_cloud
from msg_adapters.pose import pose_stamped_in_base

pytestmark = pytest.mark.ros


@pytest.fixture
def ompl_node():
    rclpy.init(
        args=["--ros-args", "-p", "status_rate_hz:=20", "-p", "frames.joint_prefix:=fr3_", "-p", "ompl.no_such:=1"]
    )
    from latent_planner_ros.nodes.ompl_planner import OmplPlannerNode

    node = OmplPlannerNode()
    try:
        yield node
    finally:
        node.destroy_node()
        rclpy.shutdown()


def _set(node, name, value):
    return node.set_parameters([Parameter(name, value=value)])[0]


def test_descriptors_carry_type_description_range_and_read_only(ompl_node):
    d = ompl_node.describe_parameter("status_rate_hz")
    assert not d.dynamic_typing and d.type == Parameter.Type.DOUBLE.value
    assert "[Hz]" in d.description and d.additional_constraints == "valid range [0.01, 100]"
    assert (d.floating_point_range[0].from_value, d.floating_point_range[0].to_value) == (0.01, 100.0)
    ik = ompl_node.describe_parameter("ompl.ik.pos_tol")
    assert "[m]" in ik.description and ik.additional_constraints == "valid range > 0"
    assert ompl_node.describe_parameter("cloud_topics").read_only
    assert ompl_node.describe_parameter("frames.base_offset").read_only


def test_start_up_parameters_the_node_does_not_have_are_named(ompl_node):
    """rclpy drops them silently; run_node logs them as ignored (a misspelt name would look applied)."""
    assert undeclared_overrides(ompl_node) == ["ompl.no_such"]
    assert not ompl_node.has_parameter("ompl.no_such")


def test_an_integer_yaml_value_for_a_double_stays_a_double(ompl_node):
    assert ompl_node.get_parameter("status_rate_hz").type_ == Parameter.Type.DOUBLE
    assert ompl_node.config.status_rate_hz == 20.0
    assert _set(ompl_node, "stale_joint_states_s", 2).successful
    assert ompl_node.get_parameter("stale_joint_states_s").type_ == Parameter.Type.DOUBLE


def test_refusals_name_the_dotted_parameter(ompl_node):
    r = _set(ompl_node, "ompl.ik.pos_tol", -1.0)
    assert not r.successful and r.reason.startswith("ompl.ik.pos_tol"), r.reason
    r = _set(ompl_node, "ompl.check_step_deg", 20.0)
    assert not r.successful and "ompl.check_step_deg" in r.reason, r.reason
    r = _set(ompl_node, "status_rate_hz", True)  # a bool for a double
    assert not r.successful and r.reason == "status_rate_hz: expected double, got bool True", r.reason
    assert ompl_node.config.status_rate_hz == 20.0
    r = _set(ompl_node, "cloud_topics", ["other/points"])
    assert not r.successful and "read-only" in r.reason and "cloud_topics" in r.reason


def test_use_sim_time_is_accepted(ompl_node):
    assert _set(ompl_node, "use_sim_time", True).successful
    assert ompl_node.get_parameter("use_sim_time").value is True


def test_a_status_rate_change_re_creates_the_timer(ompl_node):
    before = ompl_node._status_timer
    assert before.timer_period_ns == 50_000_000
    assert _set(ompl_node, "status_rate_hz", 50.0).successful
    assert ompl_node._status_timer is not before and ompl_node._status_timer.timer_period_ns == 20_000_000


def test_joint_prefix_reads_fr3_joint_states(ompl_node):
    names = [f"fr3_joint{i}" for i in range(1, 8)]
    ompl_node._on_joint_states(JointState(name=names, position=[0.1] * 7))
    assert ompl_node._q is not None and np.allclose(ompl_node._q, 0.1)
    ompl_node._on_joint_states(JointState(name=[f"panda_joint{i}" for i in range(1, 8)], position=[0.2] * 7))
    assert "fr3_joint1" in ompl_node._last_error and np.allclose(ompl_node._q, 0.1)


def test_a_cloud_in_an_unknown_frame_is_refused_with_the_shared_reason(ompl_node):
    ompl_node._on_cloud("camera/points", xyz_to_cloud(np.zeros((3, 3), np.float32), "camera_depth_optical_frame"))
    assert "frame 'camera_depth_optical_frame' has no transform to 'fr3_link0'" in ompl_node._last_error


# -- the shared, ROS-free pieces every node uses -------------------------------------------------------------
def test_goals_in_world_and_the_base_frame_and_with_a_base_offset():
    frames = FramesConfig().frames()
    q = np.array([0.0, 0.0, 0.0, 1.0])
    for frame in ("world", "panda_link0", ""):
        target = pose_stamped_in_base(target_to_pose_stamped([0.4, 0.1, 0.3], q, frame_id=frame), frames)
        assert np.allclose(target.position, [0.4, 0.1, 0.3]) and target.frame_id == "panda_link0"
    with pytest.raises(AdapterError, match="frame 'tool0' has no transform"):
        pose_stamped_in_base(target_to_pose_stamped([0.4, 0.1, 0.3], q, frame_id="tool0"), frames)
    # the base 1 m along x in world, turned 90 deg about z: world (1, 0.5, 0.3) is base (0.5, 0, 0.3)
    frames = FramesConfig(base_offset=(1.0, 0.0, 0.0, 0.0, 0.0, np.pi / 2)).frames()
    target = pose_stamped_in_base(target_to_pose_stamped([1.0, 0.5, 0.3], q, frame_id="world"), frames)
    assert np.allclose(target.position, [0.5, 0.0, 0.3])
    assert np.allclose(target.rotation @ [1.0, 0.0, 0.0], [0.0, -1.0, 0.0])  # world x is base -y
    target = pose_stamped_in_base(target_to_pose_stamped([0.5, 0.0, 0.3], q, frame_id="panda_link0"), frames)
    assert np.allclose(target.position, [0.5, 0.0, 0.3])


def test_clouds_in_an_extrinsic_frame_are_transformed_others_refused():
    config = FramesConfig(extrinsics="cam: 0 0 1 0 0 0; tilted: 0 0 0 0 0 0 1")
    fusion = CloudFusion(["camera/points"], config.frames())
    fusion.add_cloud("camera/points", np.array([[0.1, 0.2, 0.3]]), "cam", 1.0)
    assert np.allclose(fusion.fuse().points, [[0.1, 0.2, 1.3]])
    with pytest.raises(CloudRefused, match="camera/points refused: frame 'camera_depth_optical_frame' has no"):
        fusion.add_cloud("camera/points", np.zeros((1, 3)), "camera_depth_optical_frame", 1.0)


@pytest.mark.parametrize(
    ("field", "value", "message"),
    [
        ("base_offset", (0.0, 0.0), "base_offset"),
        ("base_offset", (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0), "zero quaternion"),
        ("extrinsics", "cam 0 0 0 0 0 0", "extrinsics"),
        ("extrinsics", "world: 0 0 0 0 0 0", "world"),
        ("joint_prefix", "fr3 ", "joint_prefix"),
    ],
)
def test_bad_frames_are_refused_by_name(field, value, message):
    with pytest.raises(ValueError, match=message):
        FramesConfig(**{field: value})

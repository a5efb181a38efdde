"""Pure conversions between ROS 2 messages and numpy arrays (no nodes, no rclpy.node).

Every refusal raises :class:`AdapterError` (a ValueError) naming the problem.
"""

from msg_adapters.cylinder_markers import (
    CylinderUpdate,
    apply_marker_array,
    cylinders_to_array,
    cylinders_to_marker_array,
)
from msg_adapters.diagnostics import status_array
from msg_adapters.errors import AdapterError
from msg_adapters.joint_state import joint_state_to_q, q_to_joint_state
from msg_adapters.plan_request import plan_result_status, plan_tolerance
from msg_adapters.point_cloud import cloud_to_fields, cloud_to_xyz, feature_names, xyz_to_cloud
from msg_adapters.pose import PoseTarget, pose_stamped_to_target, target_to_pose_stamped
from msg_adapters.scene_embedding import cloud_to_embedding, embedding_to_cloud
from msg_adapters.target_box import box_to_marker, marker_to_box
from msg_adapters.trajectory import (
    ee_path_to_path,
    joint_path_to_trajectory,
    path_to_arrays,
    trajectory_to_arrays,
    trajectory_to_execution,
)

__all__ = [
    "AdapterError",
    "CylinderUpdate",
    "PoseTarget",
    "apply_marker_array",
    "box_to_marker",
    "cloud_to_embedding",
    "cloud_to_fields",
    "cloud_to_xyz",
    "cylinders_to_array",
    "cylinders_to_marker_array",
    "ee_path_to_path",
    "embedding_to_cloud",
    "feature_names",
    "joint_path_to_trajectory",
    "joint_state_to_q",
    "marker_to_box",
    "path_to_arrays",
    "plan_result_status",
    "plan_tolerance",
    "pose_stamped_to_target",
    "q_to_joint_state",
    "status_array",
    "target_to_pose_stamped",
    "trajectory_to_arrays",
    "trajectory_to_execution",
    "xyz_to_cloud",
]

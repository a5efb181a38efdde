"""The inputs of the fault-injection cases: a known scene, reachable goals, and broken messages. No rclpy.

The scene is one box on the table, off to the arm's left, given as a volumetric cloud (points on a grid
filling the box, as a fused occupancy map would give; a camera sees only its surface, see ``surface=True``).
Goals A and B are end-effector poses of two arm configurations near the ready pose, clear of the box, so a
case can always send the arm somewhere. The broken messages are what drivers and users get wrong.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from geometry_msgs.msg import PoseStamped
from sensor_msgs.msg import JointState, PointCloud2, PointField

from latent_planner_ros.robot.limits import JOINT_NAMES, Q_MAX, Q_READY
from msg_adapters import q_to_joint_state, target_to_pose_stamped, xyz_to_cloud

BOX_CENTRE = np.array([0.25, 0.42, 0.08])
"""[m] centre of the scene's box (in world, on the table)."""
BOX_HALF = np.array([0.06, 0.06, 0.08])
"""[m] half extents of the box."""
GOAL_OFFSETS = {
    "A": np.array([0.45, 0.2, 0.0, 0.3, 0.0, -0.1, 0.2]),
    "B": np.array([-0.45, 0.15, 0.0, 0.25, 0.0, 0.1, -0.2]),
}
"""[rad] the configurations Q_READY + offset whose end-effector poses are goals A and B."""


def box_cloud(
    centre=BOX_CENTRE, half=BOX_HALF, spacing: float = 0.015, surface: bool = False, frame_id: str = "world"
) -> PointCloud2:
    """A box as a cloud: grid points every `spacing` [m] filling it (or only on its six faces)."""
    axes = [
        np.linspace(c - h, c + h, max(2, int(round(2 * h / spacing)) + 1)) for c, h in zip(centre, half, strict=True)
    ]
    grid = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
    if surface:
        lo, hi = np.asarray(centre) - half, np.asarray(centre) + half
        grid = grid[np.any(np.isclose(grid, lo) | np.isclose(grid, hi), axis=1)]
    return xyz_to_cloud(grid.astype(np.float32), frame_id=frame_id)


def random_cloud(n: int, seed: int = 0, frame_id: str = "world") -> PointCloud2:
    """n points [m] spread over the workspace around the box (a dense scene for load tests)."""
    rng = np.random.default_rng(seed)
    pts = rng.uniform(BOX_CENTRE - BOX_HALF, BOX_CENTRE + BOX_HALF, size=(n, 3))
    return xyz_to_cloud(pts.astype(np.float32), frame_id=frame_id)


def goal_pose(name: str) -> PoseStamped:
    """Goal A or B: the end-effector pose (panda_hand_tcp, world) of Q_READY + GOAL_OFFSETS[name]."""
    from latent_planner_ros.robot.panda import load_panda
    from latent_planner_ros.robot.rotations import matrix_to_quat

    tf = load_panda().fk(Q_READY + GOAL_OFFSETS[name])
    return target_to_pose_stamped(tf.translation, matrix_to_quat(tf.rotation))


def pose_at(position, quaternion_xyzw=(1.0, 0.0, 0.0, 0.0)) -> PoseStamped:
    """A PoseStamped in world with the values as given (no normalisation, NaN allowed)."""
    msg = PoseStamped()
    msg.header.frame_id = "world"
    p, o = msg.pose.position, msg.pose.orientation
    p.x, p.y, p.z = (float(v) for v in position)
    o.x, o.y, o.z, o.w = (float(v) for v in quaternion_xyzw)
    return msg


def bad_goals(reference: PoseStamped) -> dict[str, tuple[PoseStamped, str]]:
    """name -> (goal, text the planner's refusal contains)."""
    p, o = reference.pose.position, reference.pose.orientation
    pos, quat = (p.x, p.y, p.z), (o.x, o.y, o.z, o.w)
    return {
        "goal_nan": (pose_at((float("nan"), pos[1], pos[2]), quat), "position has NaN or inf: [nan"),
        "goal_inf": (pose_at((pos[0], float("inf"), pos[2]), quat), ", inf, "),
        "goal_quat_nan": (pose_at(pos, (float("nan"), 0.0, 0.0, 1.0)), "orientation has NaN or inf"),
        "goal_zero_quaternion": (pose_at(pos, (0.0, 0.0, 0.0, 0.0)), "orientation has zero norm"),
        "goal_3m_away": (pose_at((3.0, 0.0, 0.5), quat), "beyond the reach"),
        "goal_inside_obstacle": (pose_at(BOX_CENTRE + 0.004, quat), "inside an observed obstacle"),
    }


def malformed_clouds(points: PointCloud2) -> dict[str, tuple[PointCloud2, str]]:
    """name -> (a broken copy of `points`, text the planner's refusal contains; "" = not refused, used as is).

    Missing and wrong fields and truncated data are refused; NaN/inf points are dropped (the rest is used);
    a cloud of zero points is a valid empty scene.
    """

    def copy() -> PointCloud2:
        return PointCloud2(
            header=points.header,
            height=points.height,
            width=points.width,
            fields=list(points.fields),
            is_bigendian=points.is_bigendian,
            point_step=points.point_step,
            row_step=points.row_step,
            data=points.data,
            is_dense=points.is_dense,
        )

    missing = copy()
    missing.fields = [f for f in points.fields if f.name != "z"]
    wrong_type = copy()
    wrong_type.fields = [
        PointField(name=f.name, offset=f.offset, datatype=PointField.UINT16 if f.name == "y" else f.datatype, count=1)
        for f in points.fields
    ]
    past_end = copy()
    past_end.fields = [
        PointField(name=f.name, offset=f.offset + (6 if f.name == "z" else 0), datatype=f.datatype, count=1)
        for f in points.fields
    ]
    truncated = copy()
    truncated.data = bytes(points.data)[: len(points.data) // 2]
    n = int(points.width) * int(points.height)
    nan = np.full((n, 3), np.nan, dtype=np.float32)
    some_inf = np.frombuffer(bytes(points.data), dtype="<f4").reshape(n, -1)[:, :3].copy()
    some_inf[::3] = np.inf
    return {
        "cloud_missing_field": (missing, "lacks fields ['z']"),
        "cloud_wrong_field_type": (wrong_type, "field 'y' is UINT16"),
        "cloud_field_past_point_step": (past_end, "extends past point_step"),
        "cloud_truncated_data": (truncated, "data is truncated"),
        "cloud_nan_points": (xyz_to_cloud(nan), ""),
        "cloud_inf_points": (xyz_to_cloud(some_inf), ""),
        "cloud_zero_points": (xyz_to_cloud(np.zeros((0, 3), dtype=np.float32)), ""),
    }


def _named(names, positions) -> JointState:
    return JointState(name=list(names), position=[float(v) for v in positions])


def _beyond_limits(q: np.ndarray) -> JointState:
    bad = np.array(q, dtype=float)
    bad[0] = Q_MAX[0] + 0.6
    return q_to_joint_state(bad)


def _nan_joint(q: np.ndarray) -> JointState:
    bad = np.array(q, dtype=float)
    bad[3] = np.nan
    return _named(JOINT_NAMES, bad)


REORDER = (6, 2, 0, 5, 1, 4, 3)

JOINT_STATE_FAULTS: dict[str, tuple[Callable[[np.ndarray], JointState], str]] = {
    "joint_states_missing_joint": (lambda q: _named(JOINT_NAMES[:6], q[:6]), "lacks joints ['panda_joint7']"),
    "joint_states_extra_joints": (
        lambda q: _named([*JOINT_NAMES, "panda_finger_joint1", "panda_finger_joint2", "belt"], [*q, 0.04, 0.04, 3.0]),
        "",
    ),
    "joint_states_reordered": (lambda q: _named([JOINT_NAMES[i] for i in REORDER], q[list(REORDER)]), ""),
    "joint_states_out_of_limits": (_beyond_limits, "outside the joint limits: panda_joint1"),
    "joint_states_nan": (_nan_joint, "NaN or inf for joints ['panda_joint4']"),
    "joint_states_length_mismatch": (lambda q: _named(JOINT_NAMES, q[:5]), "7 names but 5 positions"),
}
"""name -> (faulty joint_states for the true state q (7,), text of the planner's refusal; "" = accepted:
extra joints are ignored and the order of the names is free)."""

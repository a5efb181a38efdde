"""A human-readable summary of the robot model (used by `info`, the robot_info node and the demo)."""

from __future__ import annotations

import numpy as np

from latent_planner_ros.robot.collision import CollisionChecker
from latent_planner_ros.robot.description import panda_description
from latent_planner_ros.robot.limits import JOINT_NAMES, Q_MAX, Q_MIN, Q_READY, V_MAX
from latent_planner_ros.robot.panda import EE_FRAME, load_panda


def robot_summary() -> str:
    """Multi-line text: description files, joints with limits, collision pairs, ready-pose TCP."""
    desc = panda_description()
    panda = load_panda()
    checker = CollisionChecker()
    tcp = panda.fk(Q_READY, EE_FRAME)
    lines = [
        f"Franka Panda from {desc.urdf}",
        f"  joints (nq={panda.model.nq}), fingers locked open:",
    ]
    for name, lo, hi, v in zip(JOINT_NAMES, Q_MIN, Q_MAX, V_MAX, strict=True):
        lines.append(f"    {name}: [{lo:+.4f}, {hi:+.4f}] rad, |v| <= {v:.3f} rad/s")
    lines += [
        f"  collision geometries: {len(panda.collision_model.geometryObjects)}; "
        f"checked pairs: {len(checker.self_pairs)} self (SRDF-filtered) + {len(checker.table_pairs)} table",
        f"  {EE_FRAME} at the ready pose: position {np.round(tcp.translation, 4).tolist()} m",
    ]
    return "\n".join(lines)

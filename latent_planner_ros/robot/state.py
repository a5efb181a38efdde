"""Robot state vectors x = (q, end-effector position, end-effector 6D orientation), shape (..., 16)."""

from __future__ import annotations

import torch

from latent_planner_ros.robot.rotations import matrix_to_rot6d
from latent_planner_ros.robot.torch_fk import TorchFK

STATE_DIM = 16
Q_SLICE = slice(0, 7)
POS_SLICE = slice(7, 10)
ORI_SLICE = slice(10, 16)


def robot_state(q: torch.Tensor, fk: TorchFK) -> torch.Tensor:
    """x = (q [rad], TCP position [m], TCP rotation in 6D) for q of shape (..., 7); returns (..., 16)."""
    pos, rot = fk.ee_pose(q)
    return torch.cat([q.to(pos.dtype), pos, matrix_to_rot6d(rot)], dim=-1)

"""A reaching goal: target pose of the end effector and tolerances."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from latent_planner_ros.robot.rotations import matrix_to_quat, matrix_to_rot6d_np, quat_to_matrix


@dataclass(frozen=True)
class Goal:
    """Target pose of `panda_hand_tcp` in `world`.

    Attributes:
        position: (3,) [m].
        rotation: (3, 3) rotation matrix.
        pos_tol: position tolerance [m].
        ori_tol: orientation tolerance [rad]; ignored when the planner does not use orientation.
    """

    position: np.ndarray
    rotation: np.ndarray
    pos_tol: float = 0.01
    ori_tol: float = math.radians(15.0)

    def __post_init__(self) -> None:
        if np.shape(self.position) != (3,) or not np.all(np.isfinite(self.position)):
            raise ValueError(f"goal position must be 3 finite numbers, got {self.position!r}")
        r = np.asarray(self.rotation, dtype=float)
        if r.shape != (3, 3) or not np.all(np.isfinite(r)) or not np.allclose(r.T @ r, np.eye(3), atol=1e-5):
            raise ValueError("goal rotation must be a finite 3x3 rotation matrix")
        if not (self.pos_tol > 0 and self.ori_tol > 0):
            raise ValueError("tolerances must be positive")

    @classmethod
    def from_pose(cls, position, quaternion_xyzw, pos_tol: float = 0.01, ori_tol: float = math.radians(15.0)) -> Goal:
        """From a position (3,) [m] and a quaternion (x, y, z, w) (normalised here; zero/NaN refused)."""
        return cls(np.asarray(position, dtype=float), quat_to_matrix(quaternion_xyzw), pos_tol, ori_tol)

    @property
    def rot6d(self) -> np.ndarray:
        return matrix_to_rot6d_np(self.rotation)

    @property
    def quaternion_xyzw(self) -> np.ndarray:
        return matrix_to_quat(self.rotation)

"""Franka Panda arm joint limits (the values of the real robot, as in its URDF and datasheet)."""

from __future__ import annotations

import numpy as np

JOINT_NAMES: tuple[str, ...] = tuple(f"panda_joint{i}" for i in range(1, 8))
"""Arm joint names in the order used everywhere for q (shape (7,))."""

Q_MIN = np.array([-2.8973, -1.7628, -2.8973, -3.0718, -2.8973, -0.0175, -2.8973])
"""Lower joint position limits [rad], shape (7,)."""

Q_MAX = np.array([2.8973, 1.7628, 2.8973, -0.0698, 2.8973, 3.7525, 2.8973])
"""Upper joint position limits [rad], shape (7,)."""

V_MAX = np.array([2.175, 2.175, 2.175, 2.175, 2.61, 2.61, 2.61])
"""Joint velocity limits [rad/s], shape (7,)."""

A_MAX = np.array([15.0, 7.5, 10.0, 12.5, 15.0, 20.0, 20.0])
"""Joint acceleration limits [rad/s^2], shape (7,) (Franka Panda datasheet)."""

J_MAX = np.array([7500.0, 3750.0, 5000.0, 6250.0, 7500.0, 10000.0, 10000.0])
"""Joint jerk limits [rad/s^3], shape (7,) (Franka Panda datasheet)."""

Q_READY = np.array([0.0, -0.785398, 0.0, -2.35619, 0.0, 1.5707, 0.785398])
"""The SRDF 'default' (ready) configuration [rad], shape (7,)."""

FINGER_OPEN = 0.04
"""Finger joint position [m] at which both fingers are held (fully open)."""


def within_limits(q: np.ndarray, margin: float = 0.0) -> np.ndarray:
    """True where every joint of q (shape (..., 7), rad) is within [Q_MIN + margin, Q_MAX - margin]."""
    q = np.asarray(q)
    return np.all((q >= Q_MIN + margin) & (q <= Q_MAX - margin), axis=-1)


def clamp(q: np.ndarray) -> np.ndarray:
    """Clamp q (shape (..., 7), rad) into the joint limits."""
    return np.clip(q, Q_MIN, Q_MAX)

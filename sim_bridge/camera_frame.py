"""The one place where a camera's optical frame (data/camera.py: z forward, x right, y down) meets MuJoCo's camera
frame (OpenGL: x right, y up, looking along -z).

The two frames share x and flip y and z, a rotation of 180 deg about x: R_mujoco = R_optical @ diag(1, -1, -1) for
camera-to-world rotations (3, 3). The flip is its own inverse and exact in floating point (a change of sign).
"""

from __future__ import annotations

import numpy as np

_FLIP = np.array([1.0, -1.0, -1.0])
"""column signs between the two frames' camera-to-world rotations"""


def mujoco_from_optical(rotation: np.ndarray) -> np.ndarray:
    """MuJoCo camera-to-world rotation (3, 3) (an MJCF camera's orientation, `cam_xmat`) of an optical one."""
    return np.asarray(rotation, dtype=float) * _FLIP


def optical_from_mujoco(rotation: np.ndarray) -> np.ndarray:
    """Optical camera-to-world rotation (3, 3) of a MuJoCo one (`data.cam_xmat[i].reshape(3, 3)`)."""
    return np.asarray(rotation, dtype=float) * _FLIP

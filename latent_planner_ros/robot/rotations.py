"""Rotation conversions: 6D representation <-> rotation matrix <-> quaternion (x, y, z, w).

The 6D representation is the first two columns of the rotation matrix, stacked as
``(r00, r10, r20, r01, r11, r21)``; back to a matrix by Gram-Schmidt (Zhou et al., 2019).
Torch functions are differentiable and batched over leading dimensions; numpy versions wrap them.
"""

from __future__ import annotations

import numpy as np
import torch
from scipy.spatial.transform import Rotation


def matrix_to_rot6d(r: torch.Tensor) -> torch.Tensor:
    """Rotation matrices (..., 3, 3) -> 6D (..., 6): first column then second column."""
    return torch.cat([r[..., :, 0], r[..., :, 1]], dim=-1)


def rot6d_to_matrix(d6: torch.Tensor, eps: float = 1e-8) -> torch.Tensor:
    """6D (..., 6) -> rotation matrices (..., 3, 3) by Gram-Schmidt (columns b1, b2, b1 x b2)."""
    a1, a2 = d6[..., :3], d6[..., 3:]
    b1 = a1 / a1.norm(dim=-1, keepdim=True).clamp_min(eps)
    a2 = a2 - (b1 * a2).sum(-1, keepdim=True) * b1
    b2 = a2 / a2.norm(dim=-1, keepdim=True).clamp_min(eps)
    b3 = torch.linalg.cross(b1, b2, dim=-1)
    return torch.stack([b1, b2, b3], dim=-1)


def rotation_angle_between(r1: torch.Tensor, r2: torch.Tensor) -> torch.Tensor:
    """Geodesic angle [rad] between rotation matrices (..., 3, 3), shape (...)."""
    tr = (r1.transpose(-1, -2) @ r2).diagonal(dim1=-2, dim2=-1).sum(-1)
    return torch.arccos(((tr - 1.0) / 2.0).clamp(-1.0, 1.0))


def matrix_to_rot6d_np(r: np.ndarray) -> np.ndarray:
    """numpy version of :func:`matrix_to_rot6d`: (..., 3, 3) -> (..., 6)."""
    return matrix_to_rot6d(torch.as_tensor(np.asarray(r, dtype=float))).numpy()


def rot6d_to_matrix_np(d6: np.ndarray) -> np.ndarray:
    """numpy version of :func:`rot6d_to_matrix`: (..., 6) -> (..., 3, 3)."""
    return rot6d_to_matrix(torch.as_tensor(np.asarray(d6, dtype=float))).numpy()


def quat_to_matrix(q_xyzw: np.ndarray) -> np.ndarray:
    """Quaternions (..., 4) in (x, y, z, w) order -> rotation matrices (..., 3, 3).

    Raises ValueError for a non-finite or (near-)zero quaternion; others are normalised.
    """
    q = np.asarray(q_xyzw, dtype=float)
    if q.shape[-1] != 4:
        raise ValueError(f"quaternion must have 4 components (x, y, z, w), got shape {q.shape}")
    if not np.all(np.isfinite(q)):
        raise ValueError("quaternion has non-finite components")
    norm = np.linalg.norm(q, axis=-1)
    if np.any(norm < 1e-9):
        raise ValueError("quaternion has zero norm")
    flat = (q / norm[..., None]).reshape(-1, 4)
    return Rotation.from_quat(flat).as_matrix().reshape(*q.shape[:-1], 3, 3)


def matrix_to_quat(r: np.ndarray) -> np.ndarray:
    """Rotation matrices (..., 3, 3) -> unit quaternions (..., 4) in (x, y, z, w) order, w >= 0."""
    r = np.asarray(r, dtype=float)
    quat = Rotation.from_matrix(r.reshape(-1, 3, 3)).as_quat()
    quat *= np.where(quat[:, 3:4] < 0, -1.0, 1.0)
    return quat.reshape(*r.shape[:-2], 4)

"""Collision backends for AMP-LS: a differentiable cost for the optimisation and a hard check for the
explicit collision checking of interpolated steps (seed chapter 7, Algorithm 1).

Every backend sees the scene only as a point cloud (N, 3) in `world`.
"""

from __future__ import annotations

from typing import Protocol

import numpy as np
import torch


class CollisionBackend(Protocol):
    name: str

    def set_scene(self, scene, origin: np.ndarray | None = None) -> None:
        """Prepare for a new observation: a point cloud (N, 3) [m] in `world` (robot points removed) for
        geometric backends, a scene embedding (or a cloud) for the learned one; origin (3,) [m]: the camera's
        optical centre the cloud was seen from, if known (read by the learned backend only)."""
        ...

    def p_collision(self, q: torch.Tensor, z: torch.Tensor) -> torch.Tensor:
        """Differentiable collision probability (B,) of configurations q (B, 7) with latents z (B, L)."""
        ...

    def check(self, q: np.ndarray) -> np.ndarray:
        """Hard decision (M,) bool: True where configuration q[i] (M, 7) [rad] is taken as colliding."""
        ...


class NoCollision:
    """The scene is ignored (the `no collision loss` ablation and free-space planning)."""

    name = "none"

    def set_scene(self, scene, origin: np.ndarray | None = None) -> None:
        pass

    def p_collision(self, q: torch.Tensor, z: torch.Tensor) -> torch.Tensor:
        return torch.zeros(q.shape[0], dtype=q.dtype)

    def check(self, q: np.ndarray) -> np.ndarray:
        return np.zeros(len(np.atleast_2d(q)), dtype=bool)

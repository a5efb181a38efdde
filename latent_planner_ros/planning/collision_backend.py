"""Collision backends for AMP-LS: a differentiable cost for the optimisation and a hard check for the
explicit collision checking of interpolated steps (seed chapter 7, Algorithm 1).

Every backend sees the scene only as a point cloud (N, 3) in `world` (the learned one: as a scene embedding of
it, plus the raw cloud for its hard check; LSPP's: as cylinders). `CollisionBackend` declares everything the
planner, the closed loop and the nodes use; `BackendDefaults` gives the members most backends do not need.
"""

from __future__ import annotations

from contextlib import AbstractContextManager, nullcontext
from typing import Protocol

import numpy as np
import torch


class CollisionBackend(Protocol):
    name: str
    """the backend's kind: "learned", "geometric", "cylinders" or "none\""""
    takes_frames: bool
    """p_collision accepts the link frames of q (the planner then shares its FK with the backend)"""

    @property
    def mode(self) -> str:
        """What plans the current scene: `name`, or "geometric" while the learned backend stands aside (a scene
        beyond its network's box, or within `geometric_only`)."""
        ...

    def set_scene(self, scene, origin: np.ndarray | None = None) -> None:
        """Prepare for a new observation: a point cloud (N, 3) [m] in `world` (robot points removed) for
        geometric backends, a scene embedding (or a cloud) for the learned one, cylinders (K, 4) for LSPP's;
        origin (3,) [m]: the camera's optical centre the cloud was seen from, if known (read by the learned
        backend only)."""
        ...

    def set_cloud(self, cloud: np.ndarray, views: int = 1) -> None:
        """The raw cloud (N, 3) [m] of a scene given as an embedding, fused from `views` cameras: the learned
        backend's hard check also tests it geometrically (and the views decide whether the network plans); a
        no-op where set_scene already takes the cloud."""
        ...

    def p_collision(self, q: torch.Tensor, z: torch.Tensor, frames: torch.Tensor | None = None) -> torch.Tensor:
        """Differentiable collision probability (B,) of configurations q (B, 7) with latents z (B, L); frames
        (B, F, 4, 4) [m]: q's link frames, if already computed (read only where takes_frames)."""
        ...

    def check(self, q: np.ndarray) -> np.ndarray:
        """Hard decision (M,) bool: True where configuration q[i] (M, 7) [rad] is taken as colliding."""
        ...

    def geometric_only(self) -> AbstractContextManager:
        """Within the block, scenes are planned geometrically (the learned backend's retry); else nothing."""
        ...

    def link_p_collision(self, q: np.ndarray) -> dict[str, float]:
        """{link frame name: p(collision)} of one configuration q (7,) [rad], for display; {} if not known."""
        ...


class BackendDefaults:
    """Defaults of the CollisionBackend members a backend may not need (subclass and override)."""

    name = "none"
    takes_frames = False

    @property
    def mode(self) -> str:
        return self.name

    def set_cloud(self, cloud: np.ndarray, views: int = 1) -> None:
        """No-op: this backend's scene is set by set_scene alone."""

    def geometric_only(self) -> AbstractContextManager:
        return nullcontext(self)

    def link_p_collision(self, q: np.ndarray) -> dict[str, float]:
        return {}


class NoCollision(BackendDefaults):
    """The scene is ignored (the `no collision loss` ablation and free-space planning)."""

    name = "none"

    def set_scene(self, scene, origin: np.ndarray | None = None) -> None:
        pass

    def p_collision(self, q: torch.Tensor, z: torch.Tensor, frames: torch.Tensor | None = None) -> torch.Tensor:
        return torch.zeros(q.shape[0], dtype=q.dtype)

    def check(self, q: np.ndarray) -> np.ndarray:
        return np.zeros(len(np.atleast_2d(q)), dtype=bool)

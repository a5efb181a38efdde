"""The local collision predictor with its scene: a cloud indexed once, queried for any configurations.

pred = LocalPredictor.load()                 # the shipped weights (or a checkpoint stem)
scene = pred.encode(cloud, eyes)             # cloud (N, 3) [m] in `world`, eyes (3,) / (N, 3) / None
logits = pred.link_logits_q(scene, q)        # (B, L) per LABEL_LINKS link, differentiable in q (B, 7)
p = pred.p_collision_q(scene, q)             # (B,) = sigmoid of the largest link logit
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import torch
from scipy.spatial import cKDTree

from latent_planner_ros.data.link_geometry import LABEL_LINKS
from latent_planner_ros.models.local_collision import LocalCollisionNet, Neighbourhoods
from latent_planner_ros.models.local_collision_io import load_local_collision
from latent_planner_ros.robot.panda import LINK_FRAMES
from latent_planner_ros.robot.torch_fk import TorchFK


@dataclass
class LocalScene:
    """A cloud (N, 3) float32 [m] in `world`, each point's camera origin (N, 3) float32 [m] (None: unknown),
    its KD-tree (None for an empty cloud), and optionally a cheaper test near(centres (M, 3) [m], radius [m]) ->
    (M,) bool of "a point within radius" (True allowed for more) that spares the tree far anchors."""

    cloud: np.ndarray
    eyes: np.ndarray | None
    tree: cKDTree | None
    near: Callable[[np.ndarray, float], np.ndarray] | None = None


class LocalPredictor:
    """A LocalCollisionNet (frozen, eval mode) with the forward kinematics of its links."""

    uses_origin = True
    """the network reads each point's camera origin (the direction it was seen from)"""

    def __init__(self, net: LocalCollisionNet):
        self.net = net.eval().requires_grad_(False)
        self._fk = TorchFK()
        self._frames = [LINK_FRAMES.index(n) for n in LABEL_LINKS]
        self._anchors = net.anchors_np()

    @classmethod
    def load(cls, stem: str | Path | None = None) -> LocalPredictor:
        """The shipped local predictor or `stem`; raises CheckpointError for a missing or bad checkpoint."""
        return cls(load_local_collision(stem)[0])

    @staticmethod
    def encode(points: np.ndarray | torch.Tensor, eye: np.ndarray | None = None) -> LocalScene:
        """Index one cloud (N, 3) [m] seen from eye: (3,) one camera, (N, 3) one per point, or None (unknown;
        non-finite rows count as unknown too)."""
        cloud = np.asarray(points, dtype=np.float32).reshape(-1, 3)
        keep = np.isfinite(cloud).all(1)
        eyes = None
        if eye is not None:
            e = np.asarray(eye, dtype=np.float32)
            eyes = np.broadcast_to(e.reshape(3), cloud.shape) if e.size == 3 and e.shape != cloud.shape else e
            if eyes.shape != cloud.shape:
                raise ValueError(f"eye: expected shape (3,) or ({len(cloud)}, 3), got {e.shape}")
            eyes = np.ascontiguousarray(eyes[keep])
        cloud = cloud[keep]
        return LocalScene(cloud, eyes, cKDTree(cloud) if len(cloud) else None)

    def neighbourhoods(self, scene: LocalScene, frames: np.ndarray) -> Neighbourhoods:
        """The neighbourhoods of the links at poses frames (B, L, 4, 4) [m] (LABEL_LINKS order)."""
        return Neighbourhoods.of(
            scene.tree, scene.cloud, scene.eyes, frames, self._anchors, self.net.config, scene.near
        )

    def link_logits_frames(self, scene: LocalScene, frames: torch.Tensor) -> torch.Tensor:
        """Per-link logits (B, L) at the LABEL_LINKS poses frames (B, L, 4, 4) [m]; differentiable in frames."""
        nb = self.neighbourhoods(scene, frames.detach().double().numpy())
        return self.net(frames, nb)

    def link_logits_q(
        self, scene: LocalScene, q: torch.Tensor, z: torch.Tensor | None = None, poses: torch.Tensor | None = None
    ) -> torch.Tensor:
        """Per-link logits (B, L) of configurations q (B, 7) [rad] (z: not read); poses (B, L, 4, 4) [m]: the
        LABEL_LINKS poses of q if already computed. Differentiable in q (through TorchFK) or in poses."""
        if poses is None:
            poses = self._fk(q.float())[:, self._frames]
        return self.link_logits_frames(scene, poses)

    def p_collision_q(self, scene: LocalScene, q: torch.Tensor) -> torch.Tensor:
        """p(collision) (B,) of configurations q (B, 7) [rad]: the most likely link's."""
        return torch.sigmoid(self.combine(self.link_logits_q(scene, q)))

    @staticmethod
    def combine(link_logits: torch.Tensor) -> torch.Tensor:
        """The global logit (...,) of per-link logits (..., L): their maximum (a configuration collides when one
        of its links does)."""
        return link_logits.amax(-1)

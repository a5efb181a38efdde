"""Cylinder collision backend: LSPP's state-based obstacles (seed chapter 6, III-D).

The scene is a set of upright cylinders o_i = (x, y, h, r) [m] known as state, not seen as a point cloud. The
differentiable cost queries the obstacle classifier p(collision | z, o_i) once per cylinder and combines them as
p = 1 - prod_i (1 - p_i), so the planner's collision loss -log(1 - p) is the seed's obstacle loss
sum_i -log(1 - p_i). The hard check of interpolated states is exact (coal meshes against the cylinders; beyond
the seed, which has no explicit check) or switched off (`check="none"`, the seed's behaviour).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import torch

from latent_planner_ros.data.cylinders import cylinder_scene, validate_cylinders
from latent_planner_ros.data.labels import CollisionLabeler
from latent_planner_ros.models.cylinder_classifier import CylinderClassifier, load_classifier
from latent_planner_ros.planning.collision_backend import BackendDefaults

CHECKS = ("exact", "none")

CHECK_MARGIN_M = 0.01
"""[m] the exact check's cylinders are this much wider (radius) and taller than the given ones: the checked states
of a segment lie up to check_step_rad apart in every joint, and a part of the arm passing between two of them can
graze a cylinder both states clear"""


class CylinderBackend(BackendDefaults):
    """Collision backend over an LSPP cylinder classifier.

    Args:
        classifier: p(collision | z, o), trained on the planner's VAE.
        check: "exact" (coal meshes vs the cylinders) or "none" (no explicit check, as in the seed).
        margin_m: [m] the exact check's cylinders grown by this in radius and height (CHECK_MARGIN_M).
    """

    name = "cylinders"

    def __init__(self, classifier: CylinderClassifier, check: str = "exact", margin_m: float = CHECK_MARGIN_M):
        if check not in CHECKS:
            raise ValueError(f"check must be one of {CHECKS}, got {check!r}")
        if not (isinstance(margin_m, int | float) and 0.0 <= margin_m < 0.1):
            raise ValueError(f"margin_m must be a number in [0, 0.1), got {margin_m!r}")
        self.margin_m = float(margin_m)
        self.classifier = classifier.eval()
        for p in self.classifier.parameters():
            p.requires_grad_(False)
        self.check_mode = check
        self.set_scene(np.zeros((0, 4)))

    @classmethod
    def load(cls, stem: str | Path | None = None, **kwargs) -> CylinderBackend:
        """The shipped classifier (or `stem`); raises CheckpointError for a missing or bad checkpoint."""
        return cls(load_classifier(stem)[0], **kwargs)

    def set_scene(self, scene: np.ndarray, origin: np.ndarray | None = None) -> None:
        """Cylinders (K, 4) as (x, y, h, r) [m]; an empty array (any shape) means no obstacles. ValueError if bad.
        (origin is not used.)"""
        self.cylinders = validate_cylinders(scene)
        self._o = torch.as_tensor(self.cylinders, dtype=torch.float32)
        grown = self.cylinders + np.array([0.0, 0.0, self.margin_m, self.margin_m])  # (x, y, h, r) [m]
        self._labeler = CollisionLabeler(cylinder_scene(grown)) if len(self.cylinders) else None

    def p_each(self, z: torch.Tensor) -> torch.Tensor:
        """p(collision) (B, K) of latents z (B, L) with each cylinder; differentiable in z."""
        return self.classifier.p_each(z.float(), self._o).to(z.dtype)

    def p_collision(self, q: torch.Tensor, z: torch.Tensor, frames: torch.Tensor | None = None) -> torch.Tensor:
        """p(any collision) (B,) = 1 - prod_i (1 - p_i); q (B, 7) and frames are not used (the classifier reads z)."""
        p = self.p_each(z)
        return 1.0 - torch.prod(1.0 - p, dim=1) if p.shape[1] else z.new_zeros(len(z))

    def check(self, q: np.ndarray) -> np.ndarray:
        """Hard decision (M,) bool for configurations q (M, 7) [rad]: True where the arm touches a cylinder."""
        q = np.atleast_2d(np.asarray(q, dtype=float))
        if self._labeler is None or self.check_mode == "none":
            return np.zeros(len(q), dtype=bool)
        return np.asarray(self._labeler.label(q).any(axis=1))

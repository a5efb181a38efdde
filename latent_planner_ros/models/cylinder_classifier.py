"""LSPP's obstacle collision classifier p(collision | z, o) (seed chapter 6, III-D and Table I).

An MLP on the VAE latent z of a robot state and one upright cylinder o = (x, y, h, r) [m], with ELU hidden
layers and one output logit. o is standardised with the training set's statistics (stored as buffers, so they
travel with the weights). Several obstacles are handled by querying the classifier once per obstacle; the
seed's obstacle loss sum_i -log(1 - p_i) equals -log(1 - p_any) with p_any = 1 - prod_i (1 - p_i).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from pathlib import Path

import torch
from torch import nn

from latent_planner_ros.models.checkpoint import load_model, save_checkpoint
from latent_planner_ros.models.mlp import mlp
from latent_planner_ros.resources import SOURCE_DIRS, shipped_checkpoint

CHECKPOINT_DIR = SOURCE_DIRS["checkpoints"]
"""Where training ships weights (the package's own checkpoints directory); an install reads share/ as well."""
DEFAULT_CYLINDER_CLASSIFIER = "lspp_classifier"
KIND = "lspp_cylinder_classifier"


@dataclass
class CylinderClassifierConfig:
    latent: int = 7
    """dimension of z (the VAE's latent)"""
    hidden: int = 512
    """units per hidden layer (the seed: 2048; narrower for a CPU)"""
    layers: int = 4
    """hidden layers (the seed: 4)"""

    def to_dict(self) -> dict:
        return asdict(self)


class CylinderClassifier(nn.Module):
    """p(collision) of the robot state with latent z against one cylinder o."""

    # buffers (register_buffer in __init__)
    o_mean: torch.Tensor
    o_std: torch.Tensor

    def __init__(self, config: CylinderClassifierConfig | None = None):
        super().__init__()
        self.config = config or CylinderClassifierConfig()
        self.net = mlp(self.config.latent + 4, self.config.hidden, self.config.layers, 1)
        self.register_buffer("o_mean", torch.zeros(4))
        self.register_buffer("o_std", torch.ones(4))

    def set_normalisation(self, mean: torch.Tensor, std: torch.Tensor) -> None:
        """Store the statistics (4,) of the training obstacles."""
        self.o_mean.copy_(mean)
        self.o_std.copy_(std.clamp_min(1e-6))

    def forward(self, z: torch.Tensor, o: torch.Tensor) -> torch.Tensor:
        """Logits (B,) for latents z (B, L) and cylinders o (B, 4) (x, y, h, r) [m]."""
        return self.net(torch.cat([z, (o - self.o_mean) / self.o_std], dim=-1)).squeeze(-1)

    def p_each(self, z: torch.Tensor, cylinders: torch.Tensor) -> torch.Tensor:
        """p(collision) (B, K) of every latent z (B, L) with every cylinder (K, 4); differentiable in z."""
        b, k = len(z), len(cylinders)
        if k == 0:
            return z.new_zeros((b, 0))
        zz = z[:, None, :].expand(b, k, z.shape[-1]).reshape(b * k, -1)
        oo = cylinders[None].expand(b, k, 4).reshape(b * k, 4).to(z.dtype)
        return torch.sigmoid(self(zz, oo)).reshape(b, k)


def shipped_classifier_path(name: str = DEFAULT_CYLINDER_CLASSIFIER) -> Path:
    """Path stem of a shipped cylinder classifier checkpoint, found by resources.shipped_checkpoint."""
    return shipped_checkpoint(name)


def save_classifier(stem: str | Path, model: CylinderClassifier, metadata: dict) -> Path:
    meta = dict(metadata)
    meta["kind"] = KIND
    meta["architecture"] = model.config.to_dict()
    meta["normalisation"] = {"o_mean": model.o_mean.tolist(), "o_std": model.o_std.tolist(), "o": "x, y, h, r [m]"}
    return save_checkpoint(stem, model.state_dict(), meta)


def load_classifier(stem: str | Path | None = None) -> tuple[CylinderClassifier, dict]:
    """Load a classifier (default: the shipped one) in eval mode; raises CheckpointError on any problem."""
    stem = shipped_classifier_path() if stem is None else Path(stem)
    return load_model(
        stem, KIND, "an LSPP cylinder classifier", lambda a: CylinderClassifier(CylinderClassifierConfig(**a))
    )

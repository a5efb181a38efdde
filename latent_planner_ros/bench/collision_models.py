"""The two kinds of collision predictor `bench collision` scores, behind one small interface: the grid network
with its VAE (models/collision_predictor.py) and the local network (models/local_predictor.py)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import torch

from latent_planner_ros.data.camera import planning_crop
from latent_planner_ros.models.checkpoint import CheckpointError, load_checkpoint
from latent_planner_ros.models.collision_predictor import CollisionPredictor
from latent_planner_ros.models.local_collision_io import KIND as LOCAL_KIND
from latent_planner_ros.models.local_predictor import LocalPredictor

Predictor = CollisionPredictor | LocalPredictor


def load_predictor(checkpoint: Path | None, vae: Path | None) -> tuple[Predictor, dict]:
    """The predictor at `checkpoint` (default: the planners' shipped grid network), of whichever kind its metadata
    names, and its metadata; raises CheckpointError for a missing or bad checkpoint."""
    if checkpoint is not None:
        _, meta = load_checkpoint(checkpoint)
        if meta.get("kind") == LOCAL_KIND:
            if vae is not None:
                raise CheckpointError(f"checkpoint {checkpoint} is a local predictor, which reads no VAE (--vae)")
            return LocalPredictor.load(checkpoint), meta
    from latent_planner_ros.models.collision_io import load_collision_net

    return CollisionPredictor.load(checkpoint, vae), load_collision_net(checkpoint)[1]


def predictor_box(pred: Predictor) -> tuple[np.ndarray, np.ndarray]:
    """The box (min (3,), max (3,)) [m] whose points the predictor is given: the grid network's, or (the local
    network has none) the planners' crop, the arm's reach."""
    if isinstance(pred, LocalPredictor):
        low, high = planning_crop()
    else:
        low, high = pred.net.config.encoder.bounds_min, pred.net.config.encoder.bounds_max
    return np.asarray(low, dtype=float), np.asarray(high, dtype=float)


def combine(pred: Predictor, link_logits: torch.Tensor) -> torch.Tensor:
    """The global logit (B,) from per-link logits (B, L)."""
    return pred.combine(link_logits) if isinstance(pred, LocalPredictor) else pred.net.combine(link_logits)

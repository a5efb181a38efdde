"""Save and load the local collision predictor (safetensors + JSON metadata), and find the shipped weights."""

from __future__ import annotations

from pathlib import Path

from latent_planner_ros.models.checkpoint import load_model
from latent_planner_ros.models.local_collision import LocalCollisionConfig, LocalCollisionNet
from latent_planner_ros.resources import shipped_checkpoint

KIND = "local_collision_net"
SHIPPED_LOCAL_COLLISION = "local_collision"
"""stem of the shipped local collision predictor (docs/training.md)"""


def load_local_collision(stem: str | Path | None = None) -> tuple[LocalCollisionNet, dict]:
    """The local collision predictor at `stem` (default: the shipped one) in eval mode, and its metadata;
    raises CheckpointError for a missing or bad checkpoint."""
    stem = shipped_checkpoint(SHIPPED_LOCAL_COLLISION) if stem is None else Path(stem)
    return load_model(
        stem, KIND, "a local collision predictor", lambda arch: LocalCollisionNet(LocalCollisionConfig.from_dict(arch))
    )

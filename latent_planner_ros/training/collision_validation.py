"""Validation scenes of the collision predictor's training: the seen and unseen families, generated once and cached.

Shared by `train collision` (the best network by near-object AUROC on them) and `train collision --grow` (the
grown network's report).
"""

from __future__ import annotations

from pathlib import Path

from latent_planner_ros.data.camera import CameraConfig
from latent_planner_ros.data.dataset import CollisionData, DatasetConfig, generate_dataset
from latent_planner_ros.training.train_collision_trainer import EvalSet

VAL_SEED = 7
"""Seed of the validation splits ("val_seen", "val_unseen"), disjoint from training and benchmark splits."""
VAL_SHARD = 5
"""Scenes per validation shard (fixed, so runs asking for different numbers of scenes share the cache)."""


def validation_sets(
    root: Path, n_scenes: int, camera: CameraConfig, families: tuple[str, str] = ("train", "heldout")
) -> dict[str, EvalSet]:
    """Validation scenes of the seen and unseen families (generated on first use under root/val_seen and
    root/val_unseen for the tabletop families, root/val_<name>_<family> for others)."""
    out = {}
    for name, family in zip(("seen", "unseen"), families, strict=True):
        default = {"seen": "train", "unseen": "heldout"}[name] == family
        directory = root / (f"val_{name}" if default else f"val_{name}_{family}")
        cfg = DatasetConfig(family=family, scenes_per_shard=VAL_SHARD)
        generate_dataset(directory, n_scenes, split=f"val_{name}", seed=VAL_SEED, config=cfg)
        data = CollisionData.load(directory, limit=-(-n_scenes // VAL_SHARD)).first(n_scenes)
        out[name] = EvalSet(data, seed=VAL_SEED, camera=camera)
    return out

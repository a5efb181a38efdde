"""Save and load the collision network (safetensors + JSON metadata), and find the shipped weights."""

from __future__ import annotations

import hashlib
from pathlib import Path

from latent_planner_ros.models.checkpoint import CheckpointError, load_model, save_checkpoint
from latent_planner_ros.models.collision_net import CollisionNet
from latent_planner_ros.models.collision_net_config import CollisionNetConfig
from latent_planner_ros.models.scene_encoder import SceneEncoder
from latent_planner_ros.resources import SOURCE_DIRS, shipped_checkpoint

CHECKPOINT_DIR = SOURCE_DIRS["checkpoints"]
"""Where training ships weights (the package's own checkpoints directory); an install reads share/ as well."""
DEFAULT_COLLISION = "collision"
"""Stem of the shipped collision network (the scene encoder node's, and the teacher of
PLANNER_COLLISION)."""
PLANNER_COLLISION = "collision_distilled"
"""Stem of the shipped collision predictor the planners use by default: DEFAULT_COLLISION with its per-link
classifier distilled to hidden widths 64-32 (`train distil`; docs/training.md), the same scene encoder weights."""
KIND = "collision_net"


def shipped_collision_path(name: str = DEFAULT_COLLISION) -> Path:
    """Path stem of a shipped collision checkpoint, found by resources.shipped_checkpoint."""
    return shipped_checkpoint(name)


def file_sha256(path: str | Path) -> str:
    """Hex SHA-256 of a file (identifies the VAE a collision net was trained with)."""
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


def save_collision_net(stem: str | Path, net: CollisionNet, metadata: dict) -> Path:
    """Write the network's weights and `metadata` (architecture, bounds and voxel size are added)."""
    meta = dict(metadata)
    meta["kind"] = KIND
    meta["architecture"] = net.config.to_dict()
    enc = net.config.encoder
    meta["grid"] = {
        "bounds_min": list(enc.bounds_min),
        "bounds_max": list(enc.bounds_max),
        "voxel_size": enc.voxel_size,
        "shape": list(enc.grid_shape),
        "channels": enc.channels,
        "frame": "world",
    }
    meta["links"] = list(net.fk.frames)
    return save_checkpoint(stem, net.state_dict(), meta)


def load_collision_net(stem: str | Path | None = None) -> tuple[CollisionNet, dict]:
    """Load a collision network (default: the shipped one) in eval mode; raises CheckpointError on any problem."""
    stem = shipped_collision_path() if stem is None else Path(stem)
    net, meta = load_model(
        stem, KIND, "a collision network", lambda arch: CollisionNet(CollisionNetConfig.from_dict(arch))
    )
    if meta.get("links", list(net.fk.frames)) != list(net.fk.frames):
        raise CheckpointError(
            f"checkpoint {stem} was trained for links {meta['links']}, expected {list(net.fk.frames)}"
        )
    return net, meta


def load_scene_encoder(stem: str | Path | None = None) -> SceneEncoder:
    """Only the scene encoder of a collision checkpoint (what the scene_encoder node needs; no VAE)."""
    net, _ = load_collision_net(stem)
    return net.encoder

"""Save and load the robot-state VAE (safetensors + JSON metadata), and find the shipped weights."""

from __future__ import annotations

from pathlib import Path

from latent_planner_ros.models.checkpoint import load_model, save_checkpoint
from latent_planner_ros.models.vae import RobotStateVAE
from latent_planner_ros.models.vae_config import VaeConfig
from latent_planner_ros.resources import SOURCE_DIRS, shipped_checkpoint

CHECKPOINT_DIR = SOURCE_DIRS["checkpoints"]
"""Where training ships weights (the package's own checkpoints directory); an install reads share/ as well."""
DEFAULT_VAE = "vae_kinematic"
"""Stem of the shipped default VAE."""


def shipped_vae_path(name: str = DEFAULT_VAE) -> Path:
    """Path stem of a shipped VAE checkpoint (`vae_kinematic` or `vae_plain`), found by resources.shipped_checkpoint."""
    return shipped_checkpoint(name)


def save_vae(stem: str | Path, model: RobotStateVAE, metadata: dict) -> Path:
    """Write the model's weights and `metadata` (the architecture is added under "architecture")."""
    meta = dict(metadata)
    meta["kind"] = "robot_state_vae"
    meta["architecture"] = model.config.to_dict()
    meta["normalisation"] = {"x_mean": model.x_mean.tolist(), "x_std": model.x_std.tolist()}
    return save_checkpoint(stem, model.state_dict(), meta)


def load_vae(stem: str | Path | None = None) -> tuple[RobotStateVAE, dict]:
    """Load a VAE (default: the shipped one) in eval mode; raises CheckpointError naming file and problem."""
    stem = shipped_vae_path() if stem is None else Path(stem)
    return load_model(stem, "robot_state_vae", "a robot-state VAE", lambda arch: RobotStateVAE(VaeConfig(**arch)))

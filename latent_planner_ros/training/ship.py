"""Copy the best model of a training run into the package's shipped checkpoints, with its history."""

from __future__ import annotations

import json
from pathlib import Path

from latent_planner_ros.models.checkpoint import load_checkpoint, save_checkpoint
from latent_planner_ros.models.vae_io import CHECKPOINT_DIR


def ship_checkpoint(run_dir: str | Path, name: str, dest_dir: Path = CHECKPOINT_DIR) -> Path:
    """Write run_dir/best as dest_dir/name, adding the run's evaluation history (run_dir/history.json)."""
    run_dir = Path(run_dir)
    tensors, meta = load_checkpoint(run_dir / "best")
    history = run_dir / "history.json"
    if history.is_file():
        meta["history"] = json.loads(history.read_text())
    return save_checkpoint(dest_dir / name, tensors, meta)

"""``train collision --grow STEM --box-max X Y Z --out DIR``: a trained collision network over a larger box.

No training: the network's weights carry over (models/collision_box.py). Both networks are scored on the
validation scenes, each given the points of its own box, and OUT/best records the parent's training, both
boxes and both sets of metrics; `ship_checkpoint(OUT, "collision")` ships it like a trained network.
"""

from __future__ import annotations

import argparse
import json
import shlex
import sys
from pathlib import Path

import torch

from latent_planner_ros.models.checkpoint import CheckpointError
from latent_planner_ros.models.collision_box import grow_box
from latent_planner_ros.models.collision_io import file_sha256, load_collision_net, save_collision_net
from latent_planner_ros.models.vae_io import load_vae, shipped_vae_path
from latent_planner_ros.training.collision_validation import validation_sets
from latent_planner_ros.training.train_collision_config import TrainCollisionConfig
from latent_planner_ros.training.train_collision_trainer import box_camera, evaluate_net


def validation_metrics(net, vae, config: TrainCollisionConfig) -> dict:
    """val_{seen,unseen}_{loss,auroc,auroc_near,precision_near,recall_near} of `net` on clouds cropped to its box."""
    sets = validation_sets(Path(config.val_dir), config.val_scenes, box_camera(net.config))
    out = {}
    for name, ev in sets.items():
        scores = evaluate_net(net, vae, ev, config, torch.device("cpu"))
        out.update({f"val_{name}_{k}": float(v) for k, v in scores.items()})
    return out


def grow(args: argparse.Namespace, config: TrainCollisionConfig, argv: list[str]) -> int:
    torch.set_num_threads(config.threads)
    if not (args.box_min or args.box_max):
        print("train collision --grow: pass the new box (--box-max X Y Z and/or --box-min X Y Z)", file=sys.stderr)
        return 2
    try:
        net, meta = load_collision_net(args.grow)
        vae_stem = Path(args.vae) if args.vae else shipped_vae_path()
        vae, _ = load_vae(vae_stem)
    except CheckpointError as e:
        print(f"train collision --grow: {e}", file=sys.stderr)
        return 2
    expected = meta.get("vae", {}).get("sha256")
    if expected and expected != file_sha256(vae_stem.with_suffix(".safetensors")):
        print(f"train collision --grow: {args.grow} reads the latent of another VAE than {vae_stem}; pass --vae",
              file=sys.stderr)  # fmt: skip
        return 2
    enc = net.config.encoder
    low = tuple(args.box_min) if args.box_min else enc.bounds_min
    high = tuple(args.box_max) if args.box_max else enc.bounds_max
    try:
        grown = grow_box(net, low, high)
    except ValueError as e:
        print(f"train collision --grow: {e}", file=sys.stderr)
        return 2
    print(f"[train collision] {args.grow}: box {list(enc.bounds_min)}..{list(enc.bounds_max)} -> {list(low)}.."
          f"{list(high)}; scoring both on {config.val_scenes} validation scenes per family ...")  # fmt: skip
    before = validation_metrics(net, vae, config)
    after = validation_metrics(grown, vae, config)
    out = {
        **meta,
        "metrics": after,
        "box": {
            "command": "python -m latent_planner_ros train collision " + shlex.join(argv),
            "parent": str(args.grow),
            "parent_sha256": file_sha256(Path(args.grow).with_suffix(".safetensors")),
            "parent_bounds_min": list(enc.bounds_min),
            "parent_bounds_max": list(enc.bounds_max),
            "parent_metrics": before,
        },
    }
    args.out.mkdir(parents=True, exist_ok=True)
    save_collision_net(args.out / "best", grown, out)
    print(json.dumps({k: {"before": before[k], "after": after[k]} for k in after}, indent=1))
    print(f"[train collision] wrote {args.out / 'best'}")
    return 0

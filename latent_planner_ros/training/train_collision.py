"""Train the collision predictor on procedurally generated tabletop scenes.

    python -m latent_planner_ros train collision --generate N [--workers W] [--family F]  # N labelled scenes
    python -m latent_planner_ros train collision --generate N --cluster auto|ADDRESS      # ... on Ray
    python -m latent_planner_ros train collision --init STEM [--box-min X Y Z --box-max X Y Z] ...  # fine-tune
    python -m latent_planner_ros train collision [--minutes N] [--out DIR] [--vae STEM] [--resume]
    python -m latent_planner_ros train collision --grow STEM --box-max X Y Z --out DIR   # a larger box, no training

Generation writes shards to --data (default data_cache/collision/train), skipping those that exist; it can run
in the background while training: the trainer picks up new shards every `--refresh-every` steps.
Training writes OUT/last.{safetensors,json} (resumable state) and OUT/best.{safetensors,json} (the best network
by near-object AUROC on validation scenes of the training family) at every evaluation.
"""

from __future__ import annotations

import argparse
import json
import math
import shlex
import sys
import time
from dataclasses import fields, replace
from pathlib import Path

import numpy as np
import torch
from tqdm import tqdm

from latent_planner_ros.batch.executor import Executor, add_executor_args, executor_config
from latent_planner_ros.data.camera import CameraConfig
from latent_planner_ros.data.dataset import CollisionData, DatasetConfig, generate_dataset
from latent_planner_ros.data.scene_families import check_family
from latent_planner_ros.models.checkpoint import CheckpointError, load_checkpoint
from latent_planner_ros.models.collision_io import file_sha256
from latent_planner_ros.models.collision_net import CollisionNet
from latent_planner_ros.models.collision_net_config import CollisionNetConfig
from latent_planner_ros.models.scene_encoder import SceneEncoderConfig
from latent_planner_ros.models.vae_io import load_vae, shipped_vae_path
from latent_planner_ros.training.collision_validation import validation_sets
from latent_planner_ros.training.train_collision_config import TrainCollisionConfig
from latent_planner_ros.training.train_collision_trainer import CollisionTrainer, box_camera


def parse_args(argv: list[str]) -> tuple[argparse.Namespace, TrainCollisionConfig]:
    p = argparse.ArgumentParser(
        prog="latent-planner train collision", description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    p.add_argument("--out", type=Path, default=Path("runs/collision"), help="run directory (default runs/collision)")
    budget = p.add_mutually_exclusive_group()
    budget.add_argument("--minutes", type=float, help="wall-clock budget (default 60)")
    budget.add_argument("--iterations", type=int, help="iteration budget")
    p.add_argument("--resume", action="store_true", help="continue from OUT/last")
    p.add_argument("--vae", type=Path, default=None, help="VAE checkpoint stem (default: the shipped vae_kinematic)")
    p.add_argument("--device", default=None, help="cpu or cuda (default: cuda when present)")
    p.add_argument("--generate", type=int, metavar="N", help="generate N training scenes into --data, then exit")
    p.add_argument("--workers", type=int, default=1, help="processes for --generate (or CPUs of --cluster auto)")
    add_executor_args(p)
    p.add_argument("--data-seed", type=int, default=0, help="seed of the generated training split")
    p.add_argument(
        "--grow",
        type=Path,
        metavar="STEM",
        help="write the collision checkpoint STEM over the box --box-min/--box-max (its weights, no training; "
        "models/collision_box.py) to OUT/best with its validation metrics, then exit",
    )
    p.add_argument(
        "--init",
        type=Path,
        metavar="STEM",
        help="fine-tune the trained collision checkpoint STEM (its architecture and weights; over the box "
        "--box-min/--box-max when given) instead of training a new network",
    )
    p.add_argument(
        "--box-min", type=float, nargs=3, metavar=("X", "Y", "Z"), help="with --grow/--init: lower corner [m]"
    )
    p.add_argument(
        "--box-max", type=float, nargs=3, metavar=("X", "Y", "Z"), help="with --grow/--init: upper corner [m]"
    )
    p.add_argument("--active-margin", type=int, help="encode only the box around the points, grown by N voxels")
    p.add_argument("--active-min-points", type=int, help="points a voxel needs to widen the active box")
    p.add_argument("--floor-m", type=float, help="points below this height [m] give no voxel features")
    p.add_argument(
        "--no-visibility",
        action="store_true",
        help="a new network without the visibility channels (it then needs no camera origin with its clouds)",
    )
    defaults = TrainCollisionConfig()
    for f in fields(TrainCollisionConfig):
        value = getattr(defaults, f.name)
        if isinstance(value, tuple):
            p.add_argument(f"--{f.name.replace('_', '-')}", type=float, nargs=len(value), default=value)
        else:
            p.add_argument(f"--{f.name.replace('_', '-')}", type=type(value), default=value)
    args = p.parse_args(argv)
    config = TrainCollisionConfig(**{f.name: getattr(args, f.name) for f in fields(TrainCollisionConfig)})
    config.point_keep = (config.point_keep[0], config.point_keep[1])  # argparse gives a list
    if (args.minutes is not None and not args.minutes > 0) or (args.iterations is not None and args.iterations < 1):
        p.error("--minutes and --iterations must be positive")
    if args.minutes is None and args.iterations is None:
        args.minutes = 60.0
    return args, config


def initial_network(args: argparse.Namespace):
    """The network of checkpoint args.init, grown to --box-min/--box-max if given (models/collision_box.py).
    Raises CheckpointError (missing or bad checkpoint) or ValueError (a box it cannot grow to)."""
    from latent_planner_ros.models.collision_box import grow_box
    from latent_planner_ros.models.collision_io import load_collision_net

    net, _ = load_collision_net(args.init)
    enc = net.config.encoder
    if args.box_min or args.box_max:
        net = grow_box(net, args.box_min or enc.bounds_min, args.box_max or enc.bounds_max)
    changes = active_box_changes(args)
    if changes:  # the active box changes what the encoder computes, not its weights
        tuned = CollisionNet(replace(net.config, encoder=replace(net.config.encoder, **changes)))
        tuned.load_state_dict(net.state_dict())
        net = tuned
    return net


def active_box_changes(args: argparse.Namespace) -> dict:
    """The encoder fields set by --active-margin, --active-min-points and --floor-m (models/scene_encoder.py)."""
    names = {"active_margin": args.active_margin, "active_min_points": args.active_min_points, "floor_m": args.floor_m}
    return {k: v for k, v in names.items() if v is not None}


def vae_info(stem: Path) -> dict:
    info = {"path": str(stem), "sha256": file_sha256(stem.with_suffix(".safetensors"))}
    if stem.resolve().parent == shipped_vae_path().parent:
        info["name"] = stem.name
    return info


def train(args: argparse.Namespace, config: TrainCollisionConfig, argv: list[str]) -> int:
    torch.set_num_threads(config.threads)
    device = torch.device(args.device or ("cuda" if torch.cuda.is_available() else "cpu"))
    vae_stem = args.vae or shipped_vae_path()
    try:
        vae, _ = load_vae(vae_stem)
    except CheckpointError as e:
        print(f"train collision: cannot load the VAE ({e}); pass --vae STEM", file=sys.stderr)
        return 2
    data = CollisionData.load(config.data)
    if not data.scenes:
        print(f"train collision: no training shards in {config.data}; run with --generate N first", file=sys.stderr)
        return 2
    args.out.mkdir(parents=True, exist_ok=True)
    net_config = CollisionNetConfig(
        encoder=SceneEncoderConfig(visibility=not args.no_visibility, **active_box_changes(args)),
        latent=vae.config.latent,
    )
    init = None
    if args.init is not None:
        try:
            init = initial_network(args)
        except (CheckpointError, ValueError) as e:
            print(f"train collision --init: {e}", file=sys.stderr)
            return 2
        net_config = init.config
    resume = args.resume and (args.out / "last.safetensors").exists()
    if resume:
        _, state = load_checkpoint(args.out / "last")
        net_config = CollisionNetConfig.from_dict(state["architecture"])
    print(f"[train collision] {len(data.scenes)} scenes, {len(data.q)} labelled configurations; device={device}; "
          f"building validation sets ...")  # fmt: skip
    trainer = CollisionTrainer(
        config,
        net_config,
        vae,
        data,
        validation_sets(
            Path(config.val_dir),
            config.val_scenes,
            box_camera(net_config),
            (config.val_seen_family, config.val_unseen_family),
        ),
        args.out,
        device,
    )
    if init is not None and not resume:
        trainer.net.load_state_dict(init.state_dict())
    if resume:
        trainer.resume()
        print(f"[train collision] resumed at iteration {trainer.iteration} ({trainer.elapsed / 60:.1f} min)")
    meta = {
        "training": {
            "command": "python -m latent_planner_ros train collision " + shlex.join(argv),
            "config": config.to_dict(),
        },
        "vae": vae_info(Path(vae_stem)),
        **(
            {"init": {"parent": str(args.init), "sha256": file_sha256(Path(args.init).with_suffix(".safetensors"))}}
            if args.init is not None
            else {}
        ),  # fmt: skip
        "camera": {"intrinsics": CameraConfig().intrinsics.__dict__},
    }
    budget_s = math.inf if args.minutes is None else args.minutes * 60.0  # no time limit under --iterations
    total = args.iterations

    def progress() -> float:
        return min(trainer.iteration / total, 1.0) if total else min(trainer.elapsed / budget_s, 1.0)

    def lr_at(frac: float) -> float:
        return config.lr_final + 0.5 * (config.lr - config.lr_final) * (1 + np.cos(np.pi * frac))

    bar = tqdm(
        total=total or int(budget_s),
        initial=trainer.iteration if total else int(trainer.elapsed),
        unit="it" if total else "s",
        dynamic_ncols=True,
        mininterval=0.5 if sys.stderr.isatty() else 30.0,
    )
    metrics, last = None, {}
    ema: dict[str, float] = {}
    t_prev = time.monotonic()
    while progress() < 1.0:
        lr = lr_at(progress())
        last = trainer.step(lr)
        ema = {k: v if k not in ema else 0.98 * ema[k] + 0.02 * v for k, v in last.items()}
        now = time.monotonic()
        trainer.elapsed += now - t_prev
        t_prev = now
        bar.update(1 if total else int(trainer.elapsed) - bar.n)
        if trainer.iteration % config.refresh_every == 0:
            trainer.refresh()
        if trainer.iteration % config.eval_every == 0:
            metrics = trainer.evaluate(ema, lr)
            trainer.save(metrics, meta)
            t_prev = time.monotonic()
        if trainer.iteration % 10 == 0:
            bar.set_postfix(loss=f"{ema['loss']:.3f}", acc=f"{ema['acc']:.3f}", rec=f"{ema['recall']:.3f}",
                            val_auc=f"{metrics['val_seen_auroc_near']:.3f}" if metrics else "-",
                            scenes=len(trainer.data.scenes))  # fmt: skip
    bar.close()
    if not metrics or metrics["iteration"] != trainer.iteration:
        metrics = trainer.evaluate(ema, lr_at(1.0))
        trainer.save(metrics, meta)
    print(json.dumps(metrics, indent=1))
    minutes = trainer.elapsed / 60
    print(f"[train collision] {trainer.iteration} iterations in {minutes:.1f} min; best network: {args.out / 'best'}")
    return 0


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else list(argv)
    args, config = parse_args(argv)
    if args.generate:
        torch.set_num_threads(1)
        try:
            check_family(config.family)
        except ValueError as e:
            print(f"train collision --generate: {e}", file=sys.stderr)
            return 2
        cfg = DatasetConfig(family=config.family)
        with Executor(executor_config(args)) as ex:
            generate_dataset(config.data, args.generate, split="train", seed=args.data_seed, config=cfg, executor=ex)
        return 0
    if args.grow:
        from latent_planner_ros.training.grow_collision import grow

        return grow(args, config, argv)
    return train(args, config, argv)

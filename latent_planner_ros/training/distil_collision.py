"""``train distil --hidden 64 32 --out DIR``: a smaller per-link classifier distilled from a collision network.

The teacher (default: the shipped network) keeps its scene encoder and the VAE it reads; only the per-link
MLP is replaced. No labels are needed: the student learns the teacher's link logits (clamped to
+-LOGIT_CLAMP) on the inputs the planner gives it, i.e. `CollisionNet.link_inputs` for uniform joint
configurations in rendered training-family scenes, each encoded as the planner encodes a cloud. With
`--no-latent` the student does not read the VAE latent z (the teacher still does): it learns the teacher's
logits from the link poses alone, so that the planner's hard check needs no VAE encoder pass.

OUT/best holds the student with the teacher's encoder weights. Its metadata keeps the teacher's VAE, box and
camera and moves the teacher's training record under `distil.teacher_training`. It adds, under `distil`, the
command, the teacher's SHA-256, and how often the student's hard decisions (p >= threshold on the combined
logit) agree with the teacher's: on fresh training-family scenes, and on held-out-family scenes (evaluation
only). It also gives the rate of the unsafe kind of disagreement (the teacher refuses, the student accepts).

Each scene is drawn from its own generator (--seed, scene index), so the samples are the same wherever they are
made: here (default), in --workers processes, or on Ray with --cluster (batch/executor.py, docs/cluster.md).
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import math
import shlex
import sys
from pathlib import Path

import numpy as np
import torch
from tqdm import tqdm

from latent_planner_ros.batch.executor import Executor, add_executor_args, executor_config
from latent_planner_ros.data.camera import CameraConfig
from latent_planner_ros.data.render import scene_view
from latent_planner_ros.data.scene_families import check_family, generate_family_scene
from latent_planner_ros.models.checkpoint import CheckpointError
from latent_planner_ros.models.collision_io import (
    DEFAULT_COLLISION,
    file_sha256,
    load_collision_net,
    save_collision_net,
    shipped_collision_path,
)
from latent_planner_ros.models.collision_net import CollisionNet
from latent_planner_ros.models.collision_predictor import CollisionPredictor
from latent_planner_ros.perception.scene_input import crop_to_bounds
from latent_planner_ros.robot.limits import Q_MAX, Q_MIN

LOGIT_CLAMP = 12.0
"""teacher logits are clamped to +-this before regression (beyond it both are certain)"""


def scene_samples(
    predictor: CollisionPredictor, student: CollisionNet, family: str, seed: int, index: int, per_scene: int
) -> tuple[torch.Tensor, torch.Tensor]:
    """Scene `index` of (family, seed): the student's classifier inputs (per_scene, L, D) and the teacher's link
    logits (per_scene, L) for uniform configurations; its own generator (seed, index), wherever it runs."""
    net, vae = predictor.net, predictor.vae
    enc = net.config.encoder
    rng = np.random.default_rng(np.random.SeedSequence([seed, index]))
    camera = dataclasses.replace(CameraConfig(), crop_min=enc.bounds_min, crop_max=enc.bounds_max)
    cloud, origin = scene_view(generate_family_scene(rng, family), rng, camera)
    emb = predictor.encode(crop_to_bounds(cloud, enc.bounds_min, enc.bounds_max), origin)
    q = torch.as_tensor(rng.uniform(Q_MIN, Q_MAX, (per_scene, 7)), dtype=torch.float32)
    with torch.no_grad():
        z = vae.encode_q(q)[None]
        return student.link_inputs(emb.features[None], q[None], z)[0], net.link_logits(emb.features[None], q[None], z)[
            0
        ]


def _load_pair(teacher: str | None, student_config, threads: int) -> tuple[CollisionPredictor, CollisionNet]:
    """In a worker: the teacher (stem; None = shipped) and a student of `student_config` (its inputs only)."""
    torch.set_num_threads(threads)
    return CollisionPredictor.load(teacher), CollisionNet(student_config)


def _scene_task(
    pair: tuple[CollisionPredictor, CollisionNet], family: str, seed: int, index: int, per_scene: int
) -> tuple[torch.Tensor, torch.Tensor]:
    return scene_samples(*pair, family, seed, index, per_scene)


def teacher_samples(
    predictor: CollisionPredictor,
    student: CollisionNet,
    scenes: int,
    family: str,
    seed: int,
    per_scene: int,
    executor=None,
    teacher: str | None = None,
) -> tuple[torch.Tensor, torch.Tensor]:
    """The student's classifier inputs (S * per_scene, L, D) and the teacher's link logits (S * per_scene, L), scene
    by scene (`scene_samples`). With an `executor` (batch/executor.Executor) one task per scene, each worker
    loading the teacher from its stem `teacher` (None = shipped; the one `predictor` was loaded from)."""
    bar = tqdm(total=scenes, desc=f"distil: {family} scenes", unit="scene", leave=False)
    out: dict[int, tuple[torch.Tensor, torch.Tensor]] = {}
    if executor is None:
        for i in range(scenes):
            out[i] = scene_samples(predictor, student, family, seed, i, per_scene)
            bar.update()
    else:
        from latent_planner_ros.batch.executor import Job

        job = Job(_scene_task, _load_pair, (teacher, student.config, 1))
        for i, pair in executor.map(job, [(family, seed, i, per_scene) for i in range(scenes)]):
            out[i] = pair
            bar.update()
    bar.close()
    return torch.cat([out[i][0] for i in range(scenes)]), torch.cat([out[i][1] for i in range(scenes)])


def agreement(student: CollisionNet, x: torch.Tensor, y: torch.Tensor, threshold: float) -> dict:
    """Hard-decision agreement of student and teacher (logits y) on inputs x, and the unsafe-kind rate."""
    with torch.no_grad():
        s = student.combine(student.classifier(x).squeeze(-1))
    t = student.combine(y)
    cut = math.log(threshold / (1.0 - threshold))
    refuse_t, refuse_s = t >= cut, s >= cut
    return {
        "agreement": float((refuse_t == refuse_s).float().mean()),
        "teacher_refuses_student_accepts": float((refuse_t & ~refuse_s).float().mean()),
        "teacher_refusal_rate": float(refuse_t.float().mean()),
    }


def distil(args: argparse.Namespace, executor=None) -> tuple[CollisionNet, dict]:
    """Train the student; returns it and its metrics. The teacher's samples are drawn scene by scene on
    `executor` (batch/executor.Executor) when it has more than one worker or is a Ray cluster, else here."""
    if executor is not None and not (executor.config.cluster or executor.config.workers > 1):
        executor = None
    predictor = CollisionPredictor.load(args.teacher)
    teacher = predictor.net
    latent = 0 if args.no_latent else teacher.config.latent
    config = dataclasses.replace(teacher.config, hidden=tuple(args.hidden), latent=latent)
    student = CollisionNet(config)
    student.encoder.load_state_dict(teacher.encoder.state_dict())
    student.encoder.requires_grad_(False)
    torch.manual_seed(args.seed)
    x, y = teacher_samples(
        predictor, student, args.scenes, args.family, args.seed, args.per_scene, executor, args.teacher
    )
    x, y = x.reshape(-1, x.shape[-1]), y.reshape(-1).clamp(-LOGIT_CLAMP, LOGIT_CLAMP)
    steps_per_epoch = max(1, len(x) // args.batch)
    opt = torch.optim.Adam(student.classifier.parameters(), lr=args.lr)
    sched = torch.optim.lr_scheduler.CosineAnnealingLR(opt, args.epochs * steps_per_epoch)
    bar = tqdm(range(args.epochs), desc="distil: epochs", unit="epoch")
    for _ in bar:
        perm = torch.randperm(len(x))
        for k in range(steps_per_epoch):
            i = perm[k * args.batch : (k + 1) * args.batch]
            loss = (student.classifier(x[i]).squeeze(-1) - y[i]).pow(2).mean()
            opt.zero_grad(set_to_none=True)
            loss.backward()
            opt.step()
            sched.step()
        bar.set_postfix(mse=f"{loss.item():.4f}")
    student.eval()
    metrics = {"train_mse": loss.item()}
    for name, family, seed in (("train", args.family, args.seed + 1), ("heldout", args.val_family, args.seed + 2)):
        vx, vy = teacher_samples(
            predictor, student, args.val_scenes, family, seed, args.per_scene, executor, args.teacher
        )
        scores = agreement(student, vx, vy, args.threshold)
        metrics.update({f"val_{name}_{k}": v for k, v in scores.items()})
    return student, metrics


def parse_args(argv: list[str]) -> argparse.Namespace:
    p = argparse.ArgumentParser(prog="latent-planner train distil", description=__doc__.split("\n\n")[0])
    p.add_argument("--hidden", type=int, nargs="+", required=True, metavar="W", help="the student's hidden widths")
    p.add_argument("--out", type=Path, required=True, help="run directory (writes OUT/best)")
    p.add_argument("--teacher", default=None, help="teacher checkpoint stem (default: the shipped network)")
    p.add_argument(
        "--no-latent", action="store_true", help="the student reads the link poses only, not the VAE latent z"
    )
    p.add_argument("--scenes", type=int, default=1500, help="training-family scenes to learn from")
    p.add_argument("--family", default="train", help="scene family to learn from (data/scene_families.py)")
    p.add_argument("--val-family", default="heldout", help="held-out scene family of the agreement metrics")
    p.add_argument("--val-scenes", type=int, default=60, help="scenes per family for the agreement metrics")
    p.add_argument("--per-scene", type=int, default=256, help="uniform joint configurations per scene")
    p.add_argument("--epochs", type=int, default=8)
    p.add_argument("--batch", type=int, default=4096, help="link samples per step")
    p.add_argument("--lr", type=float, default=2e-3)
    p.add_argument("--threshold", type=float, default=0.2, help="p(collision) of a refusal, for the metrics")
    p.add_argument("--threads", type=int, default=2)
    p.add_argument("--seed", type=int, default=0)
    add_executor_args(p, workers=1)
    args = p.parse_args(argv)
    for name in ("scenes", "val_scenes", "per_scene", "epochs", "batch", "threads"):
        if getattr(args, name) < 1:
            p.error(f"--{name.replace('_', '-')} must be at least 1")
    if min(args.hidden) < 1:
        p.error("--hidden widths must be at least 1")
    if not (0.0 < args.threshold < 1.0) or not (args.lr > 0):
        p.error("--threshold must be in (0, 1) and --lr positive")
    for family in (args.family, args.val_family):
        try:
            check_family(family)
        except ValueError as e:
            p.error(str(e))
    return args


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else list(argv)
    args = parse_args(argv)
    torch.set_num_threads(args.threads)
    teacher_stem = Path(args.teacher) if args.teacher else shipped_collision_path()
    try:
        _, meta = load_collision_net(teacher_stem)
        with Executor(executor_config(args)) as ex:
            student, metrics = distil(args, ex)
    except CheckpointError as e:
        print(f"train distil: {e}", file=sys.stderr)
        return 2
    teacher_info = {k: meta.pop(k) for k in ("training", "metrics", "history") if k in meta}
    out = {
        **meta,  # the VAE, box and camera of the teacher, which the student shares
        "metrics": {},  # the student's own validation metrics are measured by `bench collision`
        "distil": {
            "teacher_training": teacher_info,
            "command": "python -m latent_planner_ros train distil " + shlex.join(argv),
            "teacher": args.teacher or f"shipped {DEFAULT_COLLISION}",
            "teacher_sha256": file_sha256(teacher_stem.with_suffix(".safetensors")),
            "teacher_hidden": list(meta["architecture"]["hidden"]),
            "threshold": args.threshold,
            "executor": ex.name,
            "metrics": metrics,
        },
    }
    args.out.mkdir(parents=True, exist_ok=True)
    save_collision_net(args.out / "best", student, out)
    print(json.dumps(metrics, indent=1))
    print(f"[train distil] wrote {args.out / 'best'}")
    return 0

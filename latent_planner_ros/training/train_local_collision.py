"""Train the local collision predictor (models/local_collision.py) on a collision dataset.

    python -m latent_planner_ros train local-collision --data data_cache/collision/mix --minutes 20 \\
        --out runs/local_collision [--resume]

The data are the scenes and labelled configurations `train collision --generate` writes (`--family mix`: half
tabletop, half workcell, the workcells' training variants). Each scene is rendered once by 1-3 cameras (fused,
cached beside the data as `local_clouds_<seed>.npz`); a step takes `--scenes` scenes and `--queries` labelled
configurations of each (half near the objects). The loss is the global BCE (max over links) plus the mean
per-link BCE. Every `--eval-every` steps the near-object AUROC on validation scenes of the training family
(`--val`, another seed) picks OUT/best; OUT/last holds the resumable state. Validation scenes of held-out
families (`--val-unseen`) are scored for the record only.
"""

from __future__ import annotations

import argparse
import json
import shlex
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np
import torch
import torch.nn.functional as F
from tqdm import tqdm

from latent_planner_ros.data.dataset import CollisionData
from latent_planner_ros.models.checkpoint import CheckpointError, load_checkpoint, load_state_into, save_checkpoint
from latent_planner_ros.models.collision_metrics import auroc, precision_recall
from latent_planner_ros.models.local_collision import LocalCollisionConfig, LocalCollisionNet
from latent_planner_ros.models.local_collision_io import KIND
from latent_planner_ros.training.local_collision_data import BatchMaker, SceneClouds, cat_neighbourhoods

THRESHOLD = 0.5
"""p(collision) of the precision/recall figures logged during training"""


def parse_args(argv: list[str]) -> argparse.Namespace:
    p = argparse.ArgumentParser(
        prog="latent-planner train local-collision",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("--data", type=Path, default=Path("data_cache/collision/mix"), help="training dataset directory")
    p.add_argument("--val", type=Path, default=Path("data_cache/collision/val_seen_mix"),
                   help="validation scenes of the training family (model selection)")  # fmt: skip
    p.add_argument("--val-unseen", type=Path, default=Path("data_cache/collision/val_unseen_mix_heldout"),
                   help="validation scenes of held-out families (recorded, not used to select)")  # fmt: skip
    p.add_argument("--out", type=Path, default=Path("runs/local_collision"), help="run directory")
    budget = p.add_mutually_exclusive_group()
    budget.add_argument("--minutes", type=float, help="wall-clock budget of this run (default 20)")
    budget.add_argument("--iterations", type=int, help="iteration budget (in total, with --resume)")
    p.add_argument("--resume", action="store_true", help="continue from OUT/last")
    p.add_argument("--scenes", type=int, default=8, help="scenes per step")
    p.add_argument("--queries", type=int, default=48, help="configurations per scene and step (half near)")
    p.add_argument("--lr", type=float, default=1e-3, help="Adam learning rate (cosine decay to a tenth)")
    p.add_argument("--eval-every", type=int, default=250, help="steps between validations")
    p.add_argument("--seed", type=int, default=0, help="seed of the batches and of the clouds")
    p.add_argument("--views", type=int, nargs=2, default=(1, 3), help="cameras fused per training cloud (range)")
    p.add_argument("--workers", type=int, default=2, help="processes rendering the clouds")
    p.add_argument("--threads", type=int, default=2, help="torch threads")
    p.add_argument("--k", type=int, default=LocalCollisionConfig.k, help="nearest points per anchor")
    p.add_argument("--hidden", type=int, default=LocalCollisionConfig.hidden, help="point MLP width")
    args = p.parse_args(argv)
    if args.scenes < 1 or args.queries < 2 or args.lr <= 0 or args.eval_every < 1:
        p.error("--scenes, --queries, --lr and --eval-every must be positive (--queries at least 2)")
    return args


def _load_data(path: Path, what: str) -> CollisionData:
    data = CollisionData.load(path)
    if not data.scenes:
        raise SystemExit(f"train local-collision: no {what} shards in {path} (make them with `train collision "
                         f"--generate N --family mix --data {path}`)")  # fmt: skip
    return data


@torch.no_grad()
def evaluate(net: LocalCollisionNet, maker: BatchMaker, per_scene: int = 128) -> dict:
    """Near-object and overall AUROC, and near precision/recall at THRESHOLD, on up to per_scene configurations of
    every scene of the maker's data (the first rows of each kind: the same ones every time)."""
    net.eval()
    p, y, near = [], [], []
    for s, rows in enumerate(maker.rows):
        d = maker.data
        pick = np.concatenate([rows[d.near[rows]][: per_scene // 2], rows[~d.near[rows]][: per_scene // 2]])
        frames, nb = maker.scene_batch(s, pick)
        p.append(torch.sigmoid(net(frames, nb).amax(-1)).numpy())
        y.append(d.labels[pick])
        near.append(d.near[pick])
    net.train()
    pa, ya, na = np.concatenate(p), np.concatenate(y), np.concatenate(near)
    prec, rec = precision_recall(pa[na], ya[na], THRESHOLD)
    return {"auroc": auroc(pa, ya), "auroc_near": auroc(pa[na], ya[na]), "precision_near": prec, "recall_near": rec}


def _step(net, opt, maker: BatchMaker, rng: np.random.Generator, args) -> float:
    frames, nbs, labels = [], [], []
    for s in rng.choice(len(maker.rows), args.scenes, replace=len(maker.rows) < args.scenes):
        rows = maker.rows[s]
        near = rows[maker.data.near[rows]]
        far = rows[~maker.data.near[rows]]
        half = args.queries // 2
        pick = np.concatenate([
            rng.choice(near, half) if len(near) else rng.choice(rows, half),
            rng.choice(far, args.queries - half) if len(far) else rng.choice(rows, args.queries - half),
        ])  # fmt: skip
        f, nb = maker.scene_batch(int(s), pick)
        frames.append(f)
        nbs.append(nb)
        labels.append(maker.labels(pick))
    logits = net(torch.cat(frames), cat_neighbourhoods(nbs))
    y_link = torch.cat(labels)
    loss = F.binary_cross_entropy_with_logits(logits.amax(-1), y_link.amax(-1)) + F.binary_cross_entropy_with_logits(
        logits, y_link
    )
    opt.zero_grad()
    loss.backward()
    opt.step()
    return float(loss.detach())


def _save(stem: Path, net: LocalCollisionNet, state: dict, meta: dict) -> None:
    """The network's weights and the run's state (iteration, time, best score, history) as a checkpoint."""
    save_checkpoint(stem, {k: v.detach().clone() for k, v in net.state_dict().items()}, {**meta, **state})


def main(argv: list[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    args = parse_args(argv)
    torch.set_num_threads(args.threads)
    torch.manual_seed(args.seed)
    data = _load_data(args.data, "training")
    val = _load_data(args.val, "validation")
    unseen = CollisionData.load(args.val_unseen) if args.val_unseen.exists() else None
    config = LocalCollisionConfig(k=args.k, hidden=args.hidden)
    net = LocalCollisionNet(config)
    opt = torch.optim.Adam(net.parameters(), lr=args.lr)
    views = (int(args.views[0]), int(args.views[1]))
    cache = args.data / f"local_clouds_{args.seed}.npz"
    clouds = SceneClouds.cached(cache, data.scenes, args.seed, views, args.workers)
    val_clouds = SceneClouds.cached(args.val / "local_clouds_eval.npz", val.scenes, 7, (3, 3), args.workers)
    makers = {"val": BatchMaker(val, val_clouds, net)}
    if unseen is not None and unseen.scenes:
        u = SceneClouds.cached(args.val_unseen / "local_clouds_eval.npz", unseen.scenes, 7, (3, 3), args.workers)
        makers["val_unseen"] = BatchMaker(unseen, u, net)
    maker = BatchMaker(data, clouds, net)
    state: dict[str, Any] = {"iteration": 0, "elapsed_s": 0.0, "best": -1.0, "history": []}
    args.out.mkdir(parents=True, exist_ok=True)
    if args.resume:
        try:
            tensors, saved = load_checkpoint(args.out / "last")
        except CheckpointError as e:
            print(f"train local-collision: cannot resume: {e}")
            return 2
        load_state_into(net, tensors, args.out / "last")  # Adam's moments start afresh
        state = {k: saved[k] for k in state}
    meta = {
        "kind": KIND,
        "architecture": config.to_dict(),
        "training": {
            "command": "python -m latent_planner_ros train local-collision " + shlex.join(argv),
            "data": str(args.data),
            "scenes": len(data.scenes),
            "configurations": int(len(data.q)),
            "views": list(views),
        },
    }
    rng = np.random.default_rng([args.seed, state["iteration"]])
    total = args.iterations or 10**9
    minutes = args.minutes if args.minutes is not None else (None if args.iterations else 20.0)
    start, done_before = time.monotonic(), state["elapsed_s"]
    # the cosine's length: the iteration budget, else the steps the time budget allows at about 2 steps/s
    sched_total = args.iterations or state["iteration"] + int(120 * (minutes or 20.0))
    bar = tqdm(total=None if args.iterations is None else total, initial=state["iteration"], unit="step",
               desc="train local-collision")  # fmt: skip
    losses: list[float] = []
    while state["iteration"] < total:
        if minutes is not None and time.monotonic() - start > minutes * 60:
            break
        frac = min(state["iteration"] / sched_total, 1.0)
        for g in opt.param_groups:
            g["lr"] = args.lr * (0.1 + 0.9 * 0.5 * (1 + np.cos(np.pi * frac)))
        losses.append(_step(net, opt, maker, rng, args))
        state["iteration"] += 1
        bar.update(1)
        if state["iteration"] % args.eval_every == 0:
            state["elapsed_s"] = done_before + time.monotonic() - start
            scores = {name: evaluate(net, m) for name, m in makers.items()}
            entry = {"iteration": state["iteration"], "elapsed_s": round(state["elapsed_s"], 1),
                     "train_loss": float(np.mean(losses[-args.eval_every:]))}  # fmt: skip
            for name, s in scores.items():
                entry.update({f"{name}_{k}": round(v, 4) for k, v in s.items()})
            state["history"].append(entry)
            bar.write(json.dumps(entry))
            if scores["val"]["auroc_near"] > state["best"]:
                state["best"] = scores["val"]["auroc_near"]
                _save(args.out / "best", net, state, {**meta, "metrics": entry})
            _save(args.out / "last", net, state, meta)
    bar.close()
    state["elapsed_s"] = done_before + time.monotonic() - start
    _save(args.out / "last", net, state, meta)
    print(f"train local-collision: {state['iteration']} steps, best validation near-object AUROC {state['best']:.4f}"
          f" -> {args.out / 'best'}")  # fmt: skip
    return 0

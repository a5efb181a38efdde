"""Train LSPP's obstacle classifier p(collision | z, o) on a frozen VAE (seed chapter 6, IV-B/D).

    python -m latent_planner_ros train lspp [--minutes N | --iterations N] [--out DIR] [--resume]

Data: balanced (q, o, c) samples with exact mesh labels (`data/cylinder_dataset.py`), generated on first use and
cached in --data (train: --samples, seed 1; validation: --val-samples, seed 2, never trained on). z is the VAE's
posterior mean of q, computed once. BCE with Adam and a cosine learning rate; OUT/last is resumable, OUT/best
keeps the best validation AUROC. Ship with `--ship` (copies OUT/best into the package's checkpoints).
"""

from __future__ import annotations

import argparse
import json
import math
import shlex
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np
import torch
from tqdm import tqdm

from latent_planner_ros.data.cylinder_dataset import CylinderData, generate
from latent_planner_ros.models.checkpoint import CheckpointError, load_checkpoint, load_state_into, save_checkpoint
from latent_planner_ros.models.collision_io import file_sha256
from latent_planner_ros.models.collision_metrics import auroc, precision_recall
from latent_planner_ros.models.cylinder_classifier import (
    DEFAULT_CYLINDER_CLASSIFIER,
    CylinderClassifier,
    CylinderClassifierConfig,
    save_classifier,
)
from latent_planner_ros.models.vae_io import load_vae, shipped_vae_path
from latent_planner_ros.training.ship import ship_checkpoint


def parse_args(argv: list[str]) -> argparse.Namespace:
    p = argparse.ArgumentParser(prog="latent-planner train lspp", description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)  # fmt: skip
    p.add_argument("--out", type=Path, default=Path("runs/lspp"), help="run directory (default runs/lspp)")
    budget = p.add_mutually_exclusive_group()
    budget.add_argument("--minutes", type=float, help="wall-clock budget (default 20)")
    budget.add_argument("--iterations", type=int, help="iteration budget")
    p.add_argument("--resume", action="store_true", help="continue from OUT/last")
    p.add_argument("--vae", type=Path, default=None, help="VAE checkpoint stem (default: the shipped vae_kinematic)")
    p.add_argument("--data", type=Path, default=Path("data_cache/lspp"), help="dataset cache directory")
    p.add_argument("--samples", type=int, default=200_000, help="training samples (balanced; the seed: 80k)")
    p.add_argument("--val-samples", type=int, default=20_000, help="validation samples (separate seed)")
    p.add_argument("--hidden", type=int, default=CylinderClassifierConfig.hidden, help="units per hidden layer")
    p.add_argument("--layers", type=int, default=CylinderClassifierConfig.layers, help="hidden layers")
    p.add_argument("--batch", type=int, default=256, help="batch size (the seed: 256)")
    p.add_argument("--lr", type=float, default=1e-3, help="initial Adam learning rate (cosine decay to lr/50)")
    p.add_argument("--eval-every", type=int, default=1000, help="iterations between validations")
    p.add_argument("--threads", type=int, default=2, help="torch threads")
    p.add_argument("--seed", type=int, default=0, help="seed of initialisation and batching")
    p.add_argument("--ship", action="store_true", help=f"copy OUT/best to checkpoints/{DEFAULT_CYLINDER_CLASSIFIER}")
    args = p.parse_args(argv)
    if args.minutes is None and args.iterations is None:
        args.minutes = 20.0
    return args


def dataset(root: Path, name: str, n: int, seed: int) -> CylinderData:
    """The cached set root/name-n-seed.npz, generated when missing."""
    path = root / f"{name}-{n}-seed{seed}.npz"
    if path.is_file():
        return CylinderData.load(path)
    print(f"[train lspp] generating {n} {name} samples (exact mesh labels) -> {path}")
    data = generate(n, seed)
    data.save(path)
    return data


def latents(vae, q: np.ndarray) -> torch.Tensor:
    """VAE posterior means (N, L) of configurations q (N, 7), in batches."""
    with torch.no_grad():
        return torch.cat([vae.encode_q(torch.as_tensor(c, dtype=torch.float32)) for c in np.array_split(q, 50)])


def evaluate(model: CylinderClassifier, z: torch.Tensor, o: torch.Tensor, c: np.ndarray) -> dict:
    with torch.no_grad():
        logits = torch.cat([model(zi, oi) for zi, oi in zip(z.split(8192), o.split(8192), strict=True)])
        p = torch.sigmoid(logits).numpy()
    prec, rec = precision_recall(p, c, 0.5)
    loss = float(-np.mean(np.where(c, np.log(np.clip(p, 1e-7, 1)), np.log(np.clip(1 - p, 1e-7, 1)))))
    return {"val_loss": loss, "val_acc": float(np.mean((p >= 0.5) == c)), "val_auroc": auroc(p, c),
            "val_precision": prec, "val_recall": rec}  # fmt: skip


def plot_history(history: list[dict], path: Path) -> Path:
    """Training curve: train/validation loss and validation accuracy, AUROC, recall, precision vs iteration."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    it = [h["iteration"] for h in history]
    fig, (a, b) = plt.subplots(1, 2, figsize=(10, 3.6))
    a.plot(it, [h["train_loss"] for h in history], label="train BCE (EMA)")
    a.plot(it, [h["val_loss"] for h in history], label="validation BCE")
    a.set_yscale("log")
    a.set_xlabel("iteration")
    a.legend()
    for key in ("val_acc", "val_auroc", "val_recall", "val_precision"):
        b.plot(it, [h[key] for h in history], label=key[4:])
    b.set_ylim(0.85, 1.0)
    b.set_xlabel("iteration")
    b.legend()
    for ax in (a, b):
        ax.grid(alpha=0.3)
    fig.suptitle("LSPP obstacle classifier (held-out validation set)")
    fig.savefig(path, dpi=110, bbox_inches="tight")
    plt.close(fig)
    return path


def train(args: argparse.Namespace, argv: list[str]) -> int:
    torch.set_num_threads(args.threads)
    torch.manual_seed(args.seed)
    vae_stem = args.vae or shipped_vae_path()
    try:
        vae, _ = load_vae(vae_stem)
    except CheckpointError as e:
        print(f"train lspp: cannot load the VAE ({e}); pass --vae STEM", file=sys.stderr)
        return 2
    tr = dataset(args.data, "train", args.samples, 1)
    va = dataset(args.data, "val", args.val_samples, 2)
    z_tr, z_va = latents(vae, tr.q), latents(vae, va.q)
    o_tr, o_va = torch.as_tensor(tr.o, dtype=torch.float32), torch.as_tensor(va.o, dtype=torch.float32)
    c_tr = torch.as_tensor(tr.c, dtype=torch.float32)
    model = CylinderClassifier(
        CylinderClassifierConfig(latent=vae.config.latent, hidden=args.hidden, layers=args.layers)
    )
    model.set_normalisation(o_tr.mean(0), o_tr.std(0))
    opt = torch.optim.Adam(model.parameters(), lr=args.lr)
    args.out.mkdir(parents=True, exist_ok=True)
    state: dict[str, Any] = {"iteration": 0, "elapsed_s": 0.0, "best": -math.inf, "history": []}
    if args.resume and (args.out / "last.safetensors").is_file():
        tensors, state = load_checkpoint(args.out / "last")
        load_state_into(model, {k[6:]: v for k, v in tensors.items() if k.startswith("model.")}, args.out / "last")
        sd = opt.state_dict()
        for i in range(len(list(model.parameters()))):
            sd["state"][i] = {"exp_avg": tensors[f"opt.{i}.m"], "exp_avg_sq": tensors[f"opt.{i}.v"],
                              "step": tensors[f"opt.{i}.step"].reshape(())}  # fmt: skip
        opt.load_state_dict(sd)
        print(f"[train lspp] resumed at iteration {state['iteration']} ({state['elapsed_s'] / 60:.1f} min)")
    meta = {
        "training": {"command": "python -m latent_planner_ros train lspp " + shlex.join(argv),
                     "samples": len(tr), "val_samples": len(va), "batch": args.batch, "lr": args.lr,
                     "data": "balanced (q, o, c); q feasible, o upright cylinder (x, y, h, r); exact coal labels"},
        "vae": {"name": Path(vae_stem).name, "sha256": file_sha256(Path(vae_stem).with_suffix(".safetensors"))},
    }  # fmt: skip
    budget = args.iterations if args.iterations else args.minutes * 60.0
    gen = torch.Generator().manual_seed(args.seed + state["iteration"])

    def progress() -> float:
        return min((state["iteration"] if args.iterations else state["elapsed_s"]) / budget, 1.0)

    bar = tqdm(total=int(budget), initial=int(state["iteration"] if args.iterations else state["elapsed_s"]),
               unit="it" if args.iterations else "s", dynamic_ncols=True,
               mininterval=0.5 if sys.stderr.isatty() else 30.0)  # fmt: skip
    ema, metrics, t_prev = None, None, time.monotonic()
    while progress() < 1.0:
        lr = args.lr / 50 + 0.5 * (args.lr - args.lr / 50) * (1 + math.cos(math.pi * progress()))
        for g in opt.param_groups:
            g["lr"] = lr
        idx = torch.randint(len(c_tr), (args.batch,), generator=gen)
        logits = model(z_tr[idx], o_tr[idx])
        loss = torch.nn.functional.binary_cross_entropy_with_logits(logits, c_tr[idx])
        opt.zero_grad(set_to_none=True)
        loss.backward()
        opt.step()
        state["iteration"] += 1
        acc, lv = float(((logits.detach() > 0).float() == c_tr[idx]).float().mean()), float(loss.detach())
        ema = (lv, acc) if ema is None else (0.99 * ema[0] + 0.01 * lv, 0.99 * ema[1] + 0.01 * acc)
        now = time.monotonic()
        state["elapsed_s"] += now - t_prev
        t_prev = now
        bar.update(1 if args.iterations else int(state["elapsed_s"]) - bar.n)
        if state["iteration"] % args.eval_every == 0 or progress() >= 1.0:
            metrics = {"iteration": state["iteration"], "minutes": round(state["elapsed_s"] / 60, 2), "lr": lr,
                       "train_loss": ema[0], "train_acc": ema[1], **evaluate(model, z_va, o_va, va.c)}  # fmt: skip
            state["history"].append(metrics)
            if metrics["val_auroc"] > state["best"]:
                state["best"] = metrics["val_auroc"]
                save_classifier(args.out / "best", model, {**meta, "metrics": metrics,
                                "training": {**meta["training"], "iterations": state["iteration"],
                                             "duration_s": round(state["elapsed_s"], 1)}})  # fmt: skip
            tensors = {f"model.{k}": v for k, v in model.state_dict().items()}
            for i, st in opt.state_dict()["state"].items():
                tensors.update({f"opt.{i}.m": st["exp_avg"], f"opt.{i}.v": st["exp_avg_sq"],
                                f"opt.{i}.step": torch.as_tensor(st["step"]).reshape(1).float()})  # fmt: skip
            save_checkpoint(args.out / "last", tensors, {"kind": "lspp_training_state", **state})
            (args.out / "history.json").write_text(json.dumps(state["history"], indent=1))
            t_prev = time.monotonic()
            bar.set_postfix(loss=f"{ema[0]:.3f}", acc=f"{ema[1]:.3f}", val_acc=f"{metrics['val_acc']:.3f}",
                            val_auc=f"{metrics['val_auroc']:.4f}")  # fmt: skip
    bar.close()
    if metrics:
        print(json.dumps(metrics, indent=1))
        plot_history(state["history"], args.out / "training.png")
    print(
        f"[train lspp] {state['iteration']} iterations in {state['elapsed_s'] / 60:.1f} min; best: {args.out / 'best'}"
    )
    if args.ship:
        print(f"[train lspp] shipped {ship_checkpoint(args.out, DEFAULT_CYLINDER_CLASSIFIER)}")
    return 0


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else list(argv)
    return train(parse_args(argv), argv)

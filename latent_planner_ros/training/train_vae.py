"""Train the robot-state VAE on feasible Panda states generated on the fly.

    python -m latent_planner_ros train vae [--decoder plain|kinematic] [--minutes N | --iterations N] [--out DIR]

Writes DIR/last.{safetensors,json} (resumable state) and DIR/best.{safetensors,json} (the best model by
prior-sample feasibility) at every evaluation; `--resume` continues from DIR/last.
"""

from __future__ import annotations

import argparse
import json
import math
import shlex
import sys
import time
from dataclasses import fields
from pathlib import Path

import numpy as np
import torch
from tqdm import tqdm

from latent_planner_ros.models.checkpoint import load_checkpoint, load_state_into, save_checkpoint
from latent_planner_ros.models.geco import Geco, GecoConfig
from latent_planner_ros.models.vae import RobotStateVAE
from latent_planner_ros.models.vae_config import VaeConfig
from latent_planner_ros.models.vae_io import save_vae
from latent_planner_ros.models.vae_metrics import prior_sample_metrics, reconstruction_metrics
from latent_planner_ros.robot.collision import CollisionChecker
from latent_planner_ros.robot.sampler import FeasibleSampler
from latent_planner_ros.robot.spheres import panda_spheres
from latent_planner_ros.robot.state import robot_state
from latent_planner_ros.training.vae_train_config import TrainVaeConfig


def selection_score(m: dict) -> float:
    """Model selection on prior samples: feasibility first, then consistency and reconstruction."""
    return (
        m["decoded_within_limits_frac"] * m["decoded_self_collision_free_frac"]
        - m["consistency_p95_mm"] / 1000.0
        - m["recon_q_median_rad"]
    )


class VaeTrainer:
    """Owns the model, optimiser, GECO multiplier, state pool and RNGs of one training run."""

    def __init__(self, config: TrainVaeConfig, out: Path, device: torch.device):
        self.config = config
        self.out = out
        self.device = device
        self.rng = np.random.default_rng(config.seed)
        self.gen = torch.Generator().manual_seed(config.seed)
        self.sampler = FeasibleSampler(self.rng)
        self.model = RobotStateVAE(VaeConfig(config.decoder, config.hidden, config.layers, config.latent)).to(device)
        self.opt = torch.optim.Adam(self.model.parameters(), lr=config.lr)
        self.geco = Geco(
            GecoConfig(
                tau=math.log(config.tau_start),
                alpha_ma=config.geco_alpha_ma,
                step=config.geco_step,
                lambda_init=config.lambda_init,
                lambda_min=config.lambda_min,
                lambda_max=config.lambda_max,
            )
        )
        self.iteration = 0
        self.elapsed = 0.0
        self.history: list[dict] = []
        self.best_score = -math.inf
        heldout_rng = np.random.default_rng(10_000 + config.seed)
        self.heldout = FeasibleSampler(heldout_rng).sample(config.heldout)
        self.checker = CollisionChecker()
        self.spheres = panda_spheres()
        self.pool = torch.as_tensor(self.sampler.sample(config.pool), dtype=torch.float32)

    # -- normalisation ------------------------------------------------------------------------
    def init_normalisation(self) -> None:
        with torch.no_grad():
            x = robot_state(self.pool[:100_000].to(self.device), self.model.fk)
            self.model.set_normalisation(x.mean(0), x.std(0))

    # -- schedule -----------------------------------------------------------------------------
    def progress(self, budget_iters: int | None, budget_s: float | None) -> float:
        if budget_iters:
            return min(self.iteration / budget_iters, 1.0)
        return min(self.elapsed / budget_s, 1.0) if budget_s else 0.0

    def scheduled(self, frac: float) -> tuple[float, float]:
        c = self.config
        tau = c.tau_start * (c.tau_end / c.tau_start) ** frac
        lr = c.lr_final + 0.5 * (c.lr - c.lr_final) * (1 + math.cos(math.pi * frac))
        return tau, lr

    # -- one step -----------------------------------------------------------------------------
    def step(self, tau: float, lr: float) -> dict:
        c = self.config
        idx = torch.as_tensor(self.rng.integers(0, len(self.pool), c.refresh))
        self.pool[idx] = torch.as_tensor(self.sampler.sample(c.refresh), dtype=torch.float32)
        q = self.pool[torch.as_tensor(self.rng.integers(0, len(self.pool), c.batch))].to(self.device)
        with torch.no_grad():
            x = robot_state(q, self.model.fk)
        mu, logvar = self.model.encode(x)
        z = mu + torch.randn(mu.shape, generator=self.gen).to(self.device) * (0.5 * logvar).exp()
        mse = self.model.reconstruction_error(x, self.model.decode(z)).mean()
        kl = self.model.kl(mu, logvar).mean()
        lam = self.geco.value
        loss = (kl + lam * mse * x.shape[-1]) / (1.0 + lam)
        penalty = torch.zeros(())
        if c.feasibility_weight > 0:
            penalty = self.feasibility_penalty()
            loss = loss + c.feasibility_weight * penalty
        for g in self.opt.param_groups:
            g["lr"] = lr
        self.opt.zero_grad(set_to_none=True)
        loss.backward()
        torch.nn.utils.clip_grad_norm_(self.model.parameters(), 10.0)
        self.opt.step()
        self.geco.update(math.log(max(mse.item(), 1e-12)), tau=math.log(tau))
        self.iteration += 1
        return {"loss": loss.item(), "mse": mse.item(), "kl": kl.item(), "lambda": lam, "penalty": penalty.item()}

    def feasibility_penalty(self) -> torch.Tensor:
        """Mean sphere self/table penetration [m] beyond the margin of decoded prior samples (scalar)."""
        c = self.config
        z = torch.randn(c.feasibility_batch, c.latent, generator=self.gen).to(self.device)
        q = self.model.decode(z).q
        centres = self.spheres.centres_world(self.model.fk(q))
        depth = self.spheres.self_penetration(centres) + self.spheres.table_penetration(centres)
        return torch.relu(depth - c.feasibility_margin).mean()

    # -- evaluation and checkpoints -------------------------------------------------------------
    def evaluate(self, last: dict, tau: float, lr: float) -> dict:
        self.model.eval()
        m, _ = prior_sample_metrics(
            self.model.cpu(), self.config.eval_samples, torch.Generator().manual_seed(1), self.checker
        )
        m.update(reconstruction_metrics(self.model, self.heldout[: self.config.eval_samples]))
        self.model.to(self.device).train()
        m.update({"iteration": self.iteration, "elapsed_s": round(self.elapsed, 1), "tau": tau, "lr": lr, **last})
        self.history.append(m)
        return m

    def save(self, metrics: dict, command: str) -> None:
        meta = {
            "training": {
                "command": command,
                "config": self.config.to_dict(),
                "iterations": self.iteration,
                "duration_s": round(self.elapsed, 1),
                "device": str(self.device),
                "threads": torch.get_num_threads(),
            },
            "metrics": {k: v for k, v in metrics.items() if k not in ("iteration",)},
        }
        score = selection_score(metrics)
        if score > self.best_score:
            self.best_score = score
            save_vae(self.out / "best", self.model, meta)
        opt_state = self.opt.state_dict()["state"]
        tensors = {f"model.{k}": v for k, v in self.model.state_dict().items()}
        for i, st in opt_state.items():
            tensors[f"opt.{i}.exp_avg"] = st["exp_avg"]
            tensors[f"opt.{i}.exp_avg_sq"] = st["exp_avg_sq"]
            tensors[f"opt.{i}.step"] = torch.as_tensor(st["step"]).reshape(1).float()
        state = {
            "kind": "vae_training_state",
            "config": self.config.to_dict(),
            "iteration": self.iteration,
            "elapsed_s": self.elapsed,
            "geco": self.geco.state_dict(),
            "best_score": self.best_score,
            "rng": self.rng.bit_generator.state,
            "history": self.history,
        }
        save_checkpoint(self.out / "last", tensors, state)
        (self.out / "history.json").write_text(json.dumps(self.history, indent=1))

    def resume(self) -> None:
        tensors, state = load_checkpoint(self.out / "last")
        load_state_into(self.model, {k[6:]: v for k, v in tensors.items() if k.startswith("model.")}, self.out / "last")
        sd = self.opt.state_dict()
        for i in range(len(list(self.model.parameters()))):
            if f"opt.{i}.exp_avg" in tensors:
                sd["state"][i] = {
                    "exp_avg": tensors[f"opt.{i}.exp_avg"],
                    "exp_avg_sq": tensors[f"opt.{i}.exp_avg_sq"],
                    "step": tensors[f"opt.{i}.step"].reshape(()),
                }
        self.opt.load_state_dict(sd)
        self.iteration = int(state["iteration"])
        self.elapsed = float(state["elapsed_s"])
        self.geco.load_state_dict(state["geco"])
        self.best_score = float(state["best_score"])
        self.rng.bit_generator.state = state["rng"]
        self.history = list(state["history"])


def parse_args(argv: list[str]) -> tuple[argparse.Namespace, TrainVaeConfig]:
    p = argparse.ArgumentParser(
        prog="latent-planner train vae", description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    p.add_argument("--out", type=Path, default=Path("runs/vae"), help="run directory (default runs/vae)")
    budget = p.add_mutually_exclusive_group()
    budget.add_argument("--minutes", type=float, help="wall-clock budget")
    budget.add_argument("--iterations", type=int, help="iteration budget")
    p.add_argument("--resume", action="store_true", help="continue from OUT/last")
    p.add_argument("--device", default=None, help="cpu or cuda (default: cuda when present)")
    defaults = TrainVaeConfig()
    for f in fields(TrainVaeConfig):
        p.add_argument(
            f"--{f.name.replace('_', '-')}", type=type(getattr(defaults, f.name)), default=getattr(defaults, f.name)
        )
    args = p.parse_args(argv)
    config = TrainVaeConfig(**{f.name: getattr(args, f.name) for f in fields(TrainVaeConfig)})
    VaeConfig(config.decoder, config.hidden, config.layers, config.latent)  # validates
    if (args.minutes is not None and not args.minutes > 0) or (args.iterations is not None and args.iterations < 1):
        p.error("--minutes and --iterations must be positive")
    if args.minutes is None and args.iterations is None:
        args.minutes = 60.0
    return args, config


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    try:
        args, config = parse_args(argv)
    except ValueError as e:
        print(f"train vae: {e}", file=sys.stderr)
        return 2
    torch.set_num_threads(config.threads)
    device = torch.device(args.device or ("cuda" if torch.cuda.is_available() else "cpu"))
    args.out.mkdir(parents=True, exist_ok=True)
    command = "python -m latent_planner_ros train vae " + shlex.join(argv)
    print(f"[train vae] decoder={config.decoder} device={device} out={args.out}; building the state pool ...")
    trainer = VaeTrainer(config, args.out, device)
    if args.resume and (args.out / "last.safetensors").exists():
        trainer.resume()
        print(f"[train vae] resumed at iteration {trainer.iteration} ({trainer.elapsed / 60:.1f} min)")
    else:
        trainer.init_normalisation()
    budget_s = math.inf if args.minutes is None else args.minutes * 60.0  # no time limit under --iterations
    total = args.iterations if args.iterations else None
    bar = tqdm(
        total=total or int(budget_s),
        initial=trainer.iteration if total else int(trainer.elapsed),
        unit="it" if total else "s",
        dynamic_ncols=True,
        mininterval=0.5 if sys.stderr.isatty() else 30.0,
    )
    last = {}
    metrics = None
    t_prev = time.monotonic()
    while trainer.progress(total, budget_s) < 1.0:
        tau, lr = trainer.scheduled(trainer.progress(total, budget_s))
        last = trainer.step(tau, lr)
        now = time.monotonic()
        trainer.elapsed += now - t_prev
        bar.update(1 if total else int(trainer.elapsed) - bar.n)
        t_prev = now
        if trainer.iteration % config.eval_every == 0:
            metrics = trainer.evaluate(last, tau, lr)
            trainer.save(metrics, command)
            t_prev = time.monotonic()
        if trainer.iteration % 50 == 0:
            bar.set_postfix(
                loss=f"{last['loss']:.3g}",
                kl=f"{last['kl']:.1f}",
                lam=f"{last['lambda']:.3g}",
                mse=f"{last['mse']:.2e}",
                free=f"{metrics['decoded_self_collision_free_frac']:.3f}" if metrics else "-",
                lim=f"{metrics['decoded_within_limits_frac']:.3f}" if metrics else "-",
                refresh=False,
            )
    bar.close()
    if not metrics or metrics["iteration"] != trainer.iteration:
        tau, lr = trainer.scheduled(1.0)
        metrics = trainer.evaluate(last, tau, lr)
        trainer.save(metrics, command)
    print(json.dumps({k: metrics[k] for k in sorted(metrics) if not k.startswith("lr")}, indent=1))
    print(
        f"[train vae] {trainer.iteration} iterations in {trainer.elapsed / 60:.1f} min; best model: {args.out / 'best'}"
    )
    return 0

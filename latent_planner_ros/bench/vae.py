"""`bench vae`: fidelity of the shipped robot-state VAE and of every trained variant.

Prior samples (10,000 z ~ N(0, I)): sample consistency |decoded TCP - FK(decoded q)| (seed eq. 7),
fraction within joint limits, fraction free of self and table collision. Held-out feasible states
(10,000, a seed never used in training): reconstruction errors and KL.
"""

from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np
import torch

from latent_planner_ros.bench.report import bench_parser, write_report
from latent_planner_ros.models.vae_io import DEFAULT_VAE, load_vae, shipped_vae_path
from latent_planner_ros.models.vae_metrics import prior_sample_metrics, reconstruction_metrics
from latent_planner_ros.robot.collision import CollisionChecker
from latent_planner_ros.robot.sampler import FeasibleSampler

VARIANTS = {"kinematic": "vae_kinematic", "plain": "vae_plain"}
HELDOUT_SEED = 20261123


def evaluate_variant(
    stem, n_prior: int, heldout: np.ndarray, checker: CollisionChecker
) -> tuple[dict, np.ndarray, dict]:
    model, meta = load_vae(stem)
    with torch.no_grad():
        prior, err = prior_sample_metrics(model, n_prior, torch.Generator().manual_seed(7), checker)
        recon = reconstruction_metrics(model, heldout)
    training = meta.get("training", {})
    figures = {**prior, **recon, "training_minutes": round(training.get("duration_s", 0.0) / 60.0, 1)}
    figures["training_iterations"] = training.get("iterations")
    return figures, err, meta


def main(argv: list[str]) -> int:
    p = bench_parser("vae", __doc__)
    p.add_argument("--prior-samples", type=int, default=10_000)
    p.add_argument("--heldout", type=int, default=10_000)
    args = p.parse_args(argv)
    checker = CollisionChecker()
    heldout = FeasibleSampler(np.random.default_rng(HELDOUT_SEED)).sample(args.heldout)
    variants, errors, metas = {}, {}, {}
    for variant, name in VARIANTS.items():
        stem = shipped_vae_path(name)
        if not stem.with_suffix(".safetensors").exists():
            print(f"[bench vae] no shipped {name}; skipping the {variant} variant")
            continue
        variants[variant], errors[variant], metas[variant] = evaluate_variant(
            stem, args.prior_samples, heldout, checker
        )
    default = next(v for v, n in VARIANTS.items() if n == DEFAULT_VAE)
    if default not in variants:
        raise SystemExit(f"bench vae: the shipped default {shipped_vae_path(DEFAULT_VAE)} is missing")
    results = {**variants[default], "default_variant": default, "variants": variants}

    keys = [
        ("consistency_median_mm", "consistency median [mm]", "{:.3g}"),
        ("consistency_p95_mm", "consistency p95 [mm]", "{:.3g}"),
        ("decoded_within_limits_frac", "prior samples within limits", "{:.3f}"),
        ("decoded_self_collision_free_frac", "prior samples free of self/table collision", "{:.3f}"),
        ("recon_q_median_rad", "held-out q error, median of mean abs dq [rad]", "{:.4f}"),
        ("recon_q_max_joint_median_rad", "held-out q error, median of max abs dq [rad]", "{:.4f}"),
        ("recon_pos_median_mm", "held-out TCP position error, median [mm]", "{:.2f}"),
        ("recon_ori_median_deg", "held-out TCP orientation error, median [deg]", "{:.2f}"),
        ("kl_nats", "KL to the prior [nats]", "{:.1f}"),
        ("training_minutes", "training time on this machine [min]", "{}"),
        ("training_iterations", "training iterations", "{}"),
    ]
    head = "| metric | " + " | ".join(f"{v}{' (default)' if v == default else ''}" for v in variants) + " |"
    rows = [head, "|---|" + "---|" * len(variants)]
    for key, label, fmt in keys:
        rows.append(f"| {label} | " + " | ".join(fmt.format(variants[v][key]) for v in variants) + " |")
    md = (
        f"# bench vae\n\n{args.prior_samples} prior samples and {args.heldout} held-out feasible states "
        f"(seed {HELDOUT_SEED}).\n\n" + "\n".join(rows) + "\n"
    )

    fig, ax = plt.subplots(figsize=(6, 3.5))
    for v, err in errors.items():
        ax.hist(np.log10(np.maximum(err, 1e-6)), bins=80, alpha=0.6, label=v)
    ax.set_xlabel("log10 sample consistency error [mm]")
    ax.set_ylabel("prior samples")
    ax.legend()
    ax.set_title("|decoded TCP position - FK(decoded q)|, 10k prior samples")
    figs = {"consistency": fig}

    fig, axes = plt.subplots(1, 3, figsize=(13, 3.5))
    for v, meta in metas.items():
        hist = meta.get("history", [])
        if not hist:
            continue
        t = [h["elapsed_s"] / 60 for h in hist]
        axes[0].semilogy(t, [h["recon_q_median_rad"] for h in hist], label=v)
        axes[1].plot(t, [h["decoded_self_collision_free_frac"] for h in hist], label=f"{v} collision-free")
        axes[1].plot(t, [h["decoded_within_limits_frac"] for h in hist], "--", label=f"{v} within limits")
        axes[2].plot(t, [h["kl_nats"] for h in hist], label=v)
    axes[0].set_ylabel("held-out q error [rad]")
    axes[1].set_ylabel("fraction of prior samples")
    axes[2].set_ylabel("KL [nats]")
    for ax in axes:
        ax.set_xlabel("training time [min]")
        ax.legend(fontsize=7)
    fig.suptitle("training curves (evaluations during training)")
    figs["training"] = fig
    write_report(args.out, "vae", results, md, figs, argv)
    return 0

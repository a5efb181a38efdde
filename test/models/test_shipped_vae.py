"""The shipped VAE checkpoints load and their prior samples meet a loose floor (catches a broken artifact)."""

import numpy as np
import torch

from latent_planner_ros.models.vae_io import DEFAULT_VAE, load_vae, shipped_vae_path
from latent_planner_ros.models.vae_metrics import prior_sample_metrics, reconstruction_metrics
from latent_planner_ros.robot.sampler import FeasibleSampler


def test_shipped_default_prior_samples_are_feasible_and_consistent():
    model, meta = load_vae()
    assert meta["architecture"]["decoder"] == "kinematic" and "command" in meta["training"]
    metrics, consistency = prior_sample_metrics(model, 2000, torch.Generator().manual_seed(5))
    assert metrics["decoded_within_limits_frac"] >= 0.99, metrics
    assert metrics["decoded_self_collision_free_frac"] >= 0.9, metrics
    assert np.percentile(consistency, 95) < 10.0, metrics
    q = FeasibleSampler(np.random.default_rng(6)).sample(500)
    recon = reconstruction_metrics(model, q)
    assert recon["recon_q_median_rad"] < 0.15 and recon["recon_pos_median_mm"] < 60.0, recon


def test_shipped_plain_variant_loads_and_decodes_finite_states():
    model, meta = load_vae(shipped_vae_path("vae_plain"))
    assert meta["architecture"]["decoder"] == "plain" and DEFAULT_VAE != "vae_plain"
    x = model.decode(torch.randn(200, model.config.latent, generator=torch.Generator().manual_seed(1)))
    assert torch.isfinite(x.q).all() and torch.isfinite(x.pos).all()

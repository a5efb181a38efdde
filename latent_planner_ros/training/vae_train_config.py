"""Hyperparameters of VAE training (`python -m latent_planner_ros train vae`)."""

from __future__ import annotations

from dataclasses import asdict, dataclass


@dataclass
class TrainVaeConfig:
    """Training of the robot-state VAE with GECO on a scheduled reconstruction target.

    The constraint is fed to GECO in log form, C = log(mse) - log(tau), so the multiplier's speed does not
    depend on the scale of the error; tau falls geometrically from tau_start to tau_end over the run so the
    reconstruction keeps improving instead of freezing once a fixed target is met.
    """

    decoder: str = "kinematic"
    hidden: int = 512
    layers: int = 3
    latent: int = 7
    batch: int = 256
    lr: float = 5e-4
    """Adam learning rate at the start (cosine decay to lr_final)"""
    lr_final: float = 5e-5
    tau_start: float = 3e-2
    """reconstruction target (mean squared standardised error per state dimension) at the start"""
    tau_end: float = 5e-4
    """reconstruction target at the end of the run"""
    geco_step: float = 0.005
    geco_alpha_ma: float = 0.95
    lambda_init: float = 10.0
    lambda_min: float = 1e-2
    lambda_max: float = 1e4
    feasibility_weight: float = 0.0
    """weight [1/m] of the sphere self/table-penetration penalty on decoded prior samples (0 = off, the seed)"""
    feasibility_margin: float = 0.01
    """penetration depth [m] tolerated by that penalty (the spheres over-approximate the links)"""
    feasibility_batch: int = 256
    """prior samples per iteration for the penalty"""
    pool: int = 300_000
    """feasible states held in memory; `refresh` of them are replaced by fresh samples every iteration"""
    refresh: int = 128
    heldout: int = 10_000
    eval_every: int = 2_000
    eval_samples: int = 2_000
    seed: int = 0
    threads: int = 1

    def to_dict(self) -> dict:
        return asdict(self)

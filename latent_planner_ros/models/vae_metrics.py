"""Fidelity of a robot-state VAE: prior samples (seed eq. 7, section 6.D) and held-out reconstructions."""

from __future__ import annotations

import math

import numpy as np
import torch

from latent_planner_ros.models.vae import RobotStateVAE
from latent_planner_ros.robot.collision import CollisionChecker
from latent_planner_ros.robot.limits import within_limits
from latent_planner_ros.robot.rotations import rot6d_to_matrix, rotation_angle_between
from latent_planner_ros.robot.state import robot_state
from latent_planner_ros.robot.torch_fk import TorchFK

_FK64: TorchFK | None = None


def _fk64() -> TorchFK:
    global _FK64
    if _FK64 is None:
        _FK64 = TorchFK(dtype=torch.float64)
    return _FK64


@torch.no_grad()
def prior_sample_metrics(
    model: RobotStateVAE, n: int, generator: torch.Generator, checker: CollisionChecker | None = None
) -> tuple[dict, np.ndarray]:
    """Decode n samples z ~ N(0, I) and measure them.

    Returns (metrics, consistency errors (n,) [mm]) with metrics:
        consistency_median_mm, consistency_p95_mm: |decoded TCP position - FK(decoded q)| [mm]
        decoded_within_limits_frac: fraction of decoded q inside the joint limits
        decoded_self_collision_free_frac: fraction free of self and table collision
    """
    z = torch.randn(n, model.config.latent, generator=generator)
    dec = model.decode(z)
    q = dec.q.double()
    fk_pos, _ = _fk64().ee_pose(q)
    err_mm = (dec.pos.double() - fk_pos).norm(dim=-1).numpy() * 1000.0
    q_np = q.numpy()
    checker = checker or CollisionChecker()
    free = checker.feasible(q_np)
    metrics = {
        "consistency_median_mm": float(np.median(err_mm)),
        "consistency_p95_mm": float(np.percentile(err_mm, 95)),
        "decoded_within_limits_frac": float(within_limits(q_np).mean()),
        "decoded_self_collision_free_frac": float(free.mean()),
    }
    return metrics, err_mm


@torch.no_grad()
def reconstruction_metrics(model: RobotStateVAE, q: np.ndarray) -> dict:
    """Encode (posterior mean) and decode held-out feasible configurations q (N, 7) [rad].

    Returns recon_q_median_rad (median over states of the mean absolute joint error),
    recon_q_max_joint_median_rad (median of the largest joint error), recon_pos_median_mm,
    recon_ori_median_deg and kl_nats (mean KL of the posterior to the prior).
    """
    qt = torch.as_tensor(q, dtype=torch.float32)
    x = robot_state(qt, model.fk)
    mu, logvar = model.encode(x)
    dec = model.decode(mu)
    dq = (dec.q - qt).abs()
    pos_mm = (dec.pos - x[:, 7:10]).norm(dim=-1) * 1000.0
    ang = rotation_angle_between(rot6d_to_matrix(dec.rot6d), rot6d_to_matrix(x[:, 10:16]))
    return {
        "recon_q_median_rad": float(dq.mean(-1).median()),
        "recon_q_max_joint_median_rad": float(dq.max(-1).values.median()),
        "recon_pos_median_mm": float(pos_mm.median()),
        "recon_ori_median_deg": float(ang.median() * 180.0 / math.pi),
        "kl_nats": float(model.kl(mu, logvar).mean()),
    }

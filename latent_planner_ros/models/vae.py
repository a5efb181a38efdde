"""VAE over Panda robot states x = (q, TCP position, TCP 6D orientation), with two decoder variants."""

from __future__ import annotations

import math
from dataclasses import dataclass

import torch
from torch import nn

from latent_planner_ros.models.mlp import mlp
from latent_planner_ros.models.vae_config import VaeConfig
from latent_planner_ros.robot.limits import Q_MAX, Q_MIN
from latent_planner_ros.robot.state import ORI_SLICE, POS_SLICE, Q_SLICE, STATE_DIM, robot_state
from latent_planner_ros.robot.torch_fk import TorchFK


@dataclass
class DecodedState:
    """A decoded batch; all tensors share the leading batch shape B.

    Attributes:
        x: (B, 16) state in physical units.
        q: (B, 7) joint positions [rad].
        pos: (B, 3) decoded TCP position [m] (plain decoder: predicted; kinematic: FK of q).
        rot6d: (B, 6) decoded TCP orientation.
    """

    x: torch.Tensor

    @property
    def q(self) -> torch.Tensor:
        return self.x[..., Q_SLICE]

    @property
    def pos(self) -> torch.Tensor:
        return self.x[..., POS_SLICE]

    @property
    def rot6d(self) -> torch.Tensor:
        return self.x[..., ORI_SLICE]


class RobotStateVAE(nn.Module):
    """Gaussian encoder q(z|x), decoder p(x|z), isotropic standard normal prior p(z).

    Inputs are standardised with the stored statistics `x_mean`, `x_std` (buffers, shape (16,)).
    """

    # buffers (register_buffer in __init__)
    x_mean: torch.Tensor
    x_std: torch.Tensor
    q_mid: torch.Tensor
    q_half: torch.Tensor

    def __init__(self, config: VaeConfig):
        super().__init__()
        self.config = config
        self.encoder = mlp(STATE_DIM, config.hidden, config.layers, 2 * config.latent)
        out = 7 if config.decoder == "kinematic" else STATE_DIM
        self.decoder = mlp(config.latent, config.hidden, config.layers, out)
        self.fk = TorchFK()
        self.register_buffer("x_mean", torch.zeros(STATE_DIM))
        self.register_buffer("x_std", torch.ones(STATE_DIM))
        self.register_buffer("q_mid", torch.as_tensor((Q_MAX + Q_MIN) / 2, dtype=torch.float32), persistent=False)
        self.register_buffer("q_half", torch.as_tensor((Q_MAX - Q_MIN) / 2, dtype=torch.float32), persistent=False)

    def set_normalisation(self, mean: torch.Tensor, std: torch.Tensor) -> None:
        """Store the standardisation statistics (16,) of the training states."""
        self.x_mean.copy_(mean)
        self.x_std.copy_(std.clamp_min(1e-6))

    def standardise(self, x: torch.Tensor) -> torch.Tensor:
        return (x - self.x_mean) / self.x_std

    def encode(self, x: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """Posterior mean and log-variance, each (B, latent), for states x (B, 16) in physical units."""
        h = self.encoder(self.standardise(x))
        mu, logvar = h.chunk(2, dim=-1)
        return mu, logvar.clamp(-20.0, 10.0)

    def encode_q(self, q: torch.Tensor) -> torch.Tensor:
        """Posterior mean (B, latent) of joint configurations q (B, 7) [rad] (pose from torch FK)."""
        return self.encode(robot_state(q, self.fk))[0]

    def decode(self, z: torch.Tensor) -> DecodedState:
        """Decode latents z (B, latent) into states."""
        h = self.decoder(z)
        if self.config.decoder == "kinematic":
            q = self.q_mid + self.q_half * torch.tanh(h)
            x = robot_state(q, self.fk)
        else:
            x = h * self.x_std + self.x_mean
        return DecodedState(x=x)

    def decode_q(self, z: torch.Tensor) -> torch.Tensor:
        """Decoded joint positions (B, 7) [rad] of latents z (B, latent): decode(z).q without the kinematic
        decoder's FK (for callers that need q only)."""
        h = self.decoder(z)
        if self.config.decoder == "kinematic":
            return self.q_mid + self.q_half * torch.tanh(h)
        return (h * self.x_std + self.x_mean)[..., Q_SLICE]

    @staticmethod
    def log_prior(z: torch.Tensor) -> torch.Tensor:
        """log N(z; 0, I), shape (B,) for z (B, latent)."""
        return -0.5 * (z.pow(2).sum(-1) + z.shape[-1] * math.log(2 * math.pi))

    @staticmethod
    def kl(mu: torch.Tensor, logvar: torch.Tensor) -> torch.Tensor:
        """KL(q(z|x) || N(0, I)) [nats], shape (B,)."""
        return 0.5 * (mu.pow(2) + logvar.exp() - 1.0 - logvar).sum(-1)

    def reconstruction_error(self, x: torch.Tensor, decoded: DecodedState) -> torch.Tensor:
        """Mean squared error over the 16 standardised state dimensions, shape (B,)."""
        return (self.standardise(decoded.x) - self.standardise(x)).pow(2).mean(-1)

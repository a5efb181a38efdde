"""The collision predictor used by the planner: p(collision | scene cloud, latent z) through a frozen VAE.

predictor = CollisionPredictor.load()                 # shipped weights and the VAE they were trained with
emb = predictor.encode(points, eye)                   # once per cloud (N, 3) and camera origin (3,) or None
p = predictor.p_collision(emb, z)                     # (B,), differentiable w.r.t. z (B, latent)
"""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import torch

from latent_planner_ros.models.checkpoint import CheckpointError
from latent_planner_ros.models.collision_io import file_sha256, load_collision_net
from latent_planner_ros.models.collision_net import CollisionNet
from latent_planner_ros.models.scene_encoder import SceneEmbedding
from latent_planner_ros.models.vae import RobotStateVAE
from latent_planner_ros.models.vae_io import load_vae, shipped_vae_path


class CollisionPredictor:
    """A CollisionNet tied to the VAE whose latent it reads (q = vae.decode(z).q).

    Args:
        net: the collision network (eval mode; its parameters are frozen here).
        vae: the robot-state VAE (frozen).
    """

    def __init__(self, net: CollisionNet, vae: RobotStateVAE):
        if net.reads_latent and vae.config.latent != net.config.latent:
            raise ValueError(f"VAE latent {vae.config.latent} != collision net latent {net.config.latent}")
        self.net = net.eval().requires_grad_(False)
        self.vae = vae.eval().requires_grad_(False)

    @classmethod
    def load(cls, stem: str | Path | None = None, vae: RobotStateVAE | str | Path | None = None) -> CollisionPredictor:
        """Load a checkpoint (default: shipped); the VAE defaults to the one recorded in its metadata.

        Raises CheckpointError for a missing/corrupt checkpoint; warns if the VAE's weights differ from the
        ones the network was trained with.
        """
        net, meta = load_collision_net(stem)
        info = meta.get("vae", {})
        if vae is None or isinstance(vae, str | Path):
            vae_stem = Path(vae) if vae is not None else _recorded_vae(info)
            vae_model, _ = load_vae(vae_stem)
            sha = file_sha256(Path(vae_stem).with_suffix(".safetensors"))
            if info.get("sha256") and info["sha256"] != sha:
                warnings.warn(f"VAE {vae_stem} differs from the one the collision net was trained with", stacklevel=2)
            vae = vae_model
        return cls(net, vae)

    @property
    def uses_origin(self) -> bool:
        """Whether the network reads the camera origin with each cloud (its visibility channels)."""
        return self.net.config.encoder.visibility

    def encode(self, points: np.ndarray | torch.Tensor, eye: np.ndarray | None = None) -> SceneEmbedding:
        """Embed one cloud (N, 3) float [m] in `world` (robot points removed), seen from the camera origin
        eye [m] in `world` when known: (3,) one camera, or (N, 3) one origin per point of a cloud fused from several
        cameras (None: unknown; ignored by a network without visibility channels)."""
        with torch.no_grad():
            return self.net.encoder.encode(points, eye)

    def embedding_from_points(self, centres: np.ndarray, features: np.ndarray) -> SceneEmbedding:
        """Rebuild an embedding received as voxel centres (V, 3) and features (V, C); ValueError if off-grid."""
        return SceneEmbedding.from_points(centres, features, self.net.config.encoder)

    def link_logits_q(
        self, embedding: SceneEmbedding, q: torch.Tensor, z: torch.Tensor | None, poses: torch.Tensor | None = None
    ) -> torch.Tensor:
        """Per-link logits (B, L) for configurations q (B, 7) [rad] with their latents z (B, latent) (None: the
        posterior means of q, computed only if the network reads z); poses (B, L, 4, 4) [m]: the link poses of q
        if already computed (else the network's FK)."""
        if z is None:
            z = self.latent_of(q)
        grid = embedding.features.to(q.dtype)[None]
        return self.net.link_logits(grid, q[None], z[None], None if poses is None else poses[None])[0]

    def latent_of(self, q: torch.Tensor) -> torch.Tensor:
        """The VAE posterior means (B, latent) of configurations q (B, 7) [rad], or (B, 0) for a network that
        does not read z (no encoder pass then)."""
        if not self.net.reads_latent:
            return q.new_zeros(len(q), 0)
        return self.vae.encode_q(q.to(torch.float32)).to(q.dtype)

    def link_logits(self, embedding: SceneEmbedding, z: torch.Tensor) -> torch.Tensor:
        """Per-link logits (B, L) for latents z (B, latent), with q = vae.decode(z).q."""
        return self.link_logits_q(embedding, self.vae.decode_q(z), z)

    def logit(self, embedding: SceneEmbedding, z: torch.Tensor) -> torch.Tensor:
        """Global collision logit (B,) for latents z (B, latent)."""
        return self.net.combine(self.link_logits(embedding, z))

    def p_collision(self, embedding: SceneEmbedding, z: torch.Tensor) -> torch.Tensor:
        """Probability of collision (B,) for latents z (B, latent); differentiable w.r.t. z."""
        return torch.sigmoid(self.logit(embedding, z))

    def p_collision_q(self, embedding: SceneEmbedding, q: torch.Tensor) -> torch.Tensor:
        """Probability of collision (B,) for configurations q (B, 7) [rad] (z = posterior mean of q)."""
        return torch.sigmoid(self.net.combine(self.link_logits_q(embedding, q, None)))


def _recorded_vae(info: dict) -> Path:
    """The VAE recorded at training time: the shipped one of that name, else its path, else the shipped default."""
    if info.get("name") and shipped_vae_path(info["name"]).with_suffix(".safetensors").exists():
        return shipped_vae_path(info["name"])
    path = info.get("path")
    if path and Path(path).with_suffix(".safetensors").exists():
        return Path(path)
    default = shipped_vae_path()
    if not default.with_suffix(".safetensors").exists():
        raise CheckpointError(f"no VAE for the collision predictor: {path!r} and {default} are missing")
    return default

"""Collision network: voxel scene features + robot link poses + latent z -> per-link collision logits.

The network is independent of the VAE: it takes q (for the link poses, via torch FK) and z side by side.
CollisionPredictor (collision_predictor.py) ties it to a frozen VAE so that q = decode(z).
"""

from __future__ import annotations

import numpy as np
import torch
import torch.nn.functional as F
from torch import nn

from latent_planner_ros.data.link_geometry import LABEL_LINKS, link_geometry
from latent_planner_ros.models import trilinear
from latent_planner_ros.models.collision_net_config import CollisionNetConfig
from latent_planner_ros.models.scene_encoder import SceneEncoder
from latent_planner_ros.robot.rotations import matrix_to_rot6d, matrix_to_rot6d_np
from latent_planner_ros.robot.torch_fk import TorchFK

EINSUM_BLAS_STATES = 4
"""check_logits: the link points of more configurations than this go through numpy's optimised einsum (BLAS;
measured faster from 8 states on, slower for one)"""


class CollisionNet(nn.Module):
    """Scene encoder + shared per-link classifier (L = len(LABEL_LINKS) links)."""

    # buffers (register_buffer in __init__)
    link_points: torch.Tensor
    centre: torch.Tensor
    half_extent: torch.Tensor
    one_hot: torch.Tensor

    def __init__(self, config: CollisionNetConfig):
        super().__init__()
        self.config = config
        self.encoder = SceneEncoder(config.encoder)
        n_links, k = len(LABEL_LINKS), config.points_per_link
        enc = config.encoder
        in_dim = k * (enc.channels + 3) + 6 + config.latent + n_links
        layers: list[nn.Module] = []
        for width in config.hidden:
            layers += [nn.Linear(in_dim, width), nn.ELU()]
            in_dim = width
        self.classifier = nn.Sequential(*layers, nn.Linear(in_dim, 1))
        self.fk = TorchFK(frames=LABEL_LINKS)
        lo, hi = torch.tensor(enc.bounds_min), torch.tensor(enc.bounds_max)
        self.register_buffer(
            "link_points", torch.as_tensor(link_geometry().axis_points(k), dtype=torch.float32), persistent=False
        )
        self.register_buffer("centre", (lo + hi) / 2, persistent=False)
        self.register_buffer("half_extent", (hi - lo) / 2, persistent=False)
        self.register_buffer("one_hot", torch.eye(n_links), persistent=False)
        self._link_points_np = self.link_points.double().numpy()  # (L, K, 3), for check_logits
        self._centre_np, self._half_np = self.centre.double().numpy(), self.half_extent.double().numpy()

    @property
    def n_links(self) -> int:
        return len(LABEL_LINKS)

    @property
    def reads_latent(self) -> bool:
        """Whether the classifier takes the VAE latent z (config.latent > 0)."""
        return self.config.latent > 0

    def link_inputs(
        self, grid: torch.Tensor, q: torch.Tensor, z: torch.Tensor, poses: torch.Tensor | None = None
    ) -> torch.Tensor:
        """Per-link classifier inputs (S, M, L, D) for grids (S, C, nx, ny, nz), q (S, M, 7) [rad], z (S, M, latent)
        (ignored, and may be None, when the network does not read z); poses (S, M, L, 4, 4) [m]: the link poses
        of q (LABEL_LINKS) if already computed, else this network's FK computes them."""
        s, m = q.shape[:2]
        if poses is None:
            poses = self.fk(q.reshape(-1, 7).to(self.link_points.dtype)).reshape(s, m, self.n_links, 4, 4)
        rot, pos = poses[..., :3, :3], poses[..., :3, 3]
        pts = torch.einsum("smlij,lkj->smlki", rot, self.link_points) + pos[..., None, :]  # (S, M, L, K, 3)
        norm = (pts - self.centre) / self.half_extent  # [-1, 1] over the bounds (align_corners=False convention)
        grid_xyz = norm.reshape(s, -1, 1, 1, 3).flip(-1)  # grid_sample wants (z, y, x) for a (x, y, z) volume
        feats = F.grid_sample(grid, grid_xyz, mode="bilinear", padding_mode="zeros", align_corners=False)
        feats = feats.reshape(s, grid.shape[1], m, self.n_links, -1).permute(0, 2, 3, 4, 1)  # (S, M, L, K, C)
        parts = [feats.reshape(s, m, self.n_links, -1), norm.reshape(s, m, self.n_links, -1), matrix_to_rot6d(rot)]
        if self.reads_latent:
            parts.append(z.to(feats.dtype)[:, :, None, :].expand(s, m, self.n_links, -1))
        parts.append(self.one_hot.to(feats.dtype).expand(s, m, -1, -1))
        return torch.cat(parts, -1)

    def check_logits(self, table: torch.Tensor, poses: np.ndarray) -> torch.Tensor:
        """Per-link logits (M, L) without autograd, from the grid's rows (trilinear.channels_last) and the link
        poses (M, L, 4, 4) [m] of LABEL_LINKS: `link_logits` (to float32 rounding) for the hard checks, the
        sampling done by trilinear.sample. Only for a network that does not read z."""
        if self.reads_latent:
            raise ValueError("check_logits needs a network without the latent input (config.latent 0)")
        enc = self.config.encoder
        m, n_links = len(poses), self.n_links
        rot, pos = poses[..., :3, :3], poses[..., :3, 3]
        # (M, L, K, 3); numpy's BLAS path is several times faster than its default loop from a few states on
        big = m > EINSUM_BLAS_STATES
        pts = np.einsum("mlij,lkj->mlki", rot, self._link_points_np, optimize=big) + pos[:, :, None, :]
        norm = (pts - self._centre_np) / self._half_np
        cells = ((norm + 1.0) * np.asarray(enc.grid_shape) - 1.0) / 2.0  # grid_sample's align_corners=False
        feats = trilinear.sample(table, enc.grid_shape, cells.reshape(-1, 3)).reshape(m, n_links, -1)
        rot6d = matrix_to_rot6d_np(rot)
        geometry = torch.from_numpy(np.concatenate([norm.reshape(m, n_links, -1), rot6d], -1).astype(np.float32))
        x = torch.cat([feats, geometry, self.one_hot.expand(m, -1, -1)], -1)
        with torch.no_grad():
            return self.classifier(x).squeeze(-1)

    def link_logits(
        self, grid: torch.Tensor, q: torch.Tensor, z: torch.Tensor, poses: torch.Tensor | None = None
    ) -> torch.Tensor:
        """Per-link collision logits (S, M, L) for grids (S, C, nx, ny, nz), q (S, M, 7) [rad], z (S, M, latent)
        (and the link poses (S, M, L, 4, 4) [m] of q, if known: see link_inputs)."""
        return self.classifier(self.link_inputs(grid, q, z, poses)).squeeze(-1)

    def combine(self, link_logits: torch.Tensor) -> torch.Tensor:
        """Global collision logit (...) from per-link logits (..., L)."""
        if self.config.combine == "max":
            return link_logits.max(-1).values
        return torch.logsumexp(link_logits, -1)

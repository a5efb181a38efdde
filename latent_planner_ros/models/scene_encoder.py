"""Scene encoder: a point cloud -> a grid of voxel features (SceneCollisionNet-style, sized for a CPU).

Points are voxelised over fixed workspace bounds; each point's offset from its voxel centre goes through a
small MLP, the results are max-pooled per voxel and joined by a log(1 + count) channel, then 3D convolutions
mix neighbouring voxels. The result is a SceneEmbedding, which can travel as a point cloud of voxel centres
with one float field per feature channel (f0..fC-1).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Any, cast

import numpy as np
import torch
import torch.nn.functional as F
from torch import nn

from latent_planner_ros.models import visibility as vis


@dataclass(frozen=True)
class SceneEncoderConfig:
    """Voxel grid and widths of the scene encoder."""

    bounds_min: tuple[float, float, float] = (0.0, -0.6, -0.05)
    """lower corner [m] of the encoded workspace box in `world`"""
    bounds_max: tuple[float, float, float] = (1.0, 0.6, 0.55)
    """upper corner [m]; (max - min) must be a whole number of voxels along each axis. New networks train in
    this box; the shipped one was then given a box reaching 0.95 m (`train collision --grow`, docs/training.md)"""
    voxel_size: float = 0.1
    """edge length [m] of the cubic voxels"""
    point_hidden: int = 32
    """width of the per-point MLP's hidden layer"""
    point_features: int = 32
    """per-point (and max-pooled per-voxel) feature width"""
    conv_channels: tuple[int, ...] = (32, 32, 32, 64)
    """output channels of the 3x3x3 convolutions; the last one is the embedding width"""
    visibility: bool = False
    """append what the camera saw of each voxel (free / hidden behind a surface; models/visibility.py),
    which needs the camera origin with each cloud"""
    visibility_bin: float = 0.02
    """width of the direction bins (tangent units, about radians) of the visibility channels"""
    visibility_margin_m: float = 0.03
    """a voxel sample within this range [m] of the observed surface on its ray is neither free nor hidden"""
    active_margin: int = -1
    """-1: every voxel of the box is encoded (the first shipped networks); >= 0: only the voxels of the smallest
    box around the points at or above `floor_m`, grown by this many voxels on every side, computed as if that
    box were the whole grid; the other voxels' features are 0. A box covering the arm's reach then costs what
    the part holding objects costs (the network must be trained so)"""
    active_min_points: int = 1
    """a voxel widens the active box only if it holds at least this many points at or above the floor (so that
    stray depth noise far away does not)"""
    floor_m: float | None = None
    """None: every point counts; else points below this height [m] in `world` (the table top, known exactly to
    the planners) give no voxel features and do not widen the active box; they still tell the visibility
    channels what the camera saw"""

    def __post_init__(self) -> None:
        extent = np.asarray(self.bounds_max) - np.asarray(self.bounds_min)
        cells = extent / self.voxel_size
        if np.any(extent <= 0) or np.any(np.abs(cells - np.round(cells)) > 1e-6):
            raise ValueError(
                f"bounds {self.bounds_min}..{self.bounds_max} are not a whole number of {self.voxel_size} m voxels"
            )
        if not self.conv_channels:
            raise ValueError("conv_channels must not be empty")

    @property
    def grid_shape(self) -> tuple[int, int, int]:
        """Voxels along x, y, z."""
        cells = (np.asarray(self.bounds_max) - np.asarray(self.bounds_min)) / self.voxel_size
        nx, ny, nz = (int(c) for c in np.round(cells))
        return nx, ny, nz

    @property
    def channels(self) -> int:
        """Feature channels of the embedding."""
        return self.conv_channels[-1]

    def to_dict(self) -> dict:
        return asdict(self)

    @classmethod
    def from_dict(cls, d: dict) -> SceneEncoderConfig:
        fields: dict[str, Any] = {k: tuple(v) if isinstance(v, list) else v for k, v in d.items()}
        return cls(**fields)


def voxel_centres(config: SceneEncoderConfig) -> np.ndarray:
    """Centres (V, 3) float32 [m] of all voxels, x-major order (index = (ix * ny + iy) * nz + iz)."""
    nx, ny, nz = config.grid_shape
    idx = np.stack(np.meshgrid(np.arange(nx), np.arange(ny), np.arange(nz), indexing="ij"), -1).reshape(-1, 3)
    return (np.asarray(config.bounds_min) + (idx + 0.5) * config.voxel_size).astype(np.float32)


@dataclass
class SceneEmbedding:
    """The encoded scene: a dense feature grid over the encoder's workspace bounds.

    Attributes:
        features: (C, nx, ny, nz) float32 voxel features.
        config: the encoder configuration (bounds, voxel size) the grid belongs to.
    """

    features: torch.Tensor
    config: SceneEncoderConfig

    def to_points(self) -> tuple[np.ndarray, np.ndarray]:
        """Voxel centres (V, 3) float32 [m] and their features (V, C) float32, x-major voxel order."""
        c = self.features.shape[0]
        return voxel_centres(self.config), self.features.detach().cpu().reshape(c, -1).T.contiguous().numpy()

    @classmethod
    def from_points(cls, centres: np.ndarray, features: np.ndarray, config: SceneEncoderConfig) -> SceneEmbedding:
        """Rebuild the grid from voxel centres (V, 3) and features (V, C) in any order.

        Raises ValueError if a centre is off the grid or outside the bounds, a voxel is missing or repeated,
        or the feature width differs from the config's.
        """
        centres = np.asarray(centres, dtype=float).reshape(-1, 3)
        features = np.asarray(features, dtype=np.float32)
        nx, ny, nz = config.grid_shape
        if features.ndim != 2 or features.shape != (len(centres), config.channels):
            raise ValueError(f"expected features ({len(centres)}, {config.channels}), got {features.shape}")
        if len(centres) != nx * ny * nz:
            raise ValueError(f"expected {nx * ny * nz} voxels ({nx}x{ny}x{nz}), got {len(centres)}")
        f = (centres - np.asarray(config.bounds_min)) / config.voxel_size - 0.5
        idx = np.round(f).astype(int)
        if np.abs(f - idx).max(initial=0.0) > 1e-3 or np.any(idx < 0) or np.any(idx >= (nx, ny, nz)):
            raise ValueError("voxel centres do not lie on the encoder's grid (bounds or voxel size differ)")
        flat = (idx[:, 0] * ny + idx[:, 1]) * nz + idx[:, 2]
        if len(np.unique(flat)) != len(flat):
            raise ValueError("repeated voxel centres")
        grid = np.empty((nx * ny * nz, config.channels), dtype=np.float32)
        grid[flat] = features
        return cls(torch.from_numpy(grid.T.copy()).reshape(config.channels, nx, ny, nz), config)


class SceneEncoder(nn.Module):
    """Point clouds -> voxel feature grids (B, C, nx, ny, nz)."""

    # buffers (register_buffer in __init__)
    bounds_min: torch.Tensor
    grid_dims: torch.Tensor
    centre: torch.Tensor
    samples: torch.Tensor

    def __init__(self, config: SceneEncoderConfig):
        super().__init__()
        self.config = config
        self.point_mlp = nn.Sequential(
            nn.Linear(3, config.point_hidden),
            nn.ReLU(),
            nn.Linear(config.point_hidden, config.point_features),
            nn.ReLU(),
        )
        convs: list[nn.Module] = []
        c_in = config.point_features + 1 + (vis.CHANNELS if config.visibility else 0)
        for i, c_out in enumerate(config.conv_channels):
            convs.append(nn.Conv3d(c_in, c_out, 3, padding=1))
            if i < len(config.conv_channels) - 1:
                convs.append(nn.ReLU())
            c_in = c_out
        self.convs = nn.Sequential(*convs)
        self.register_buffer("bounds_min", torch.tensor(config.bounds_min, dtype=torch.float32), persistent=False)
        self.register_buffer("grid_dims", torch.tensor(config.grid_shape), persistent=False)
        lo, hi = torch.tensor(config.bounds_min), torch.tensor(config.bounds_max)
        self.register_buffer("centre", ((lo + hi) / 2).to(torch.float32), persistent=False)
        self.register_buffer(
            "samples", vis.sub_voxel_points(self.bounds_min, config.voxel_size, config.grid_shape), persistent=False
        )

    def forward(
        self,
        points: torch.Tensor,
        batch: torch.Tensor | None = None,
        n_batch: int = 1,
        eyes: torch.Tensor | None = None,
        point_eyes: torch.Tensor | None = None,
    ) -> torch.Tensor:
        """Encode clouds.

        Args:
            points: (N, 3) points [m] in `world` of all clouds together; points outside the bounds are ignored.
            batch: (N,) int64 index of the cloud each point belongs to (default: all in cloud 0).
            n_batch: number of clouds B.
            eyes: (B, 3) camera origins [m] in `world` (a NaN row or None: unknown); used with `visibility`.
            point_eyes: (N, 3) origin [m] in `world` of the camera that saw each point (a NaN row: unknown), for
                clouds fused from several cameras; replaces `eyes` (models/visibility.py combines the cameras).
        Returns:
            (B, C, nx, ny, nz) voxel features.
        """
        cfg = self.config
        points = points.to(self.bounds_min.dtype)
        batch = torch.zeros(len(points), dtype=torch.long, device=points.device) if batch is None else batch
        if cfg.active_margin >= 0:
            return self._forward_active(points, batch, n_batch, eyes, point_eyes)
        return self._encode_grid(points, batch, n_batch, eyes, point_eyes, self.samples, self.bounds_min)

    def _encode_grid(
        self,
        points: torch.Tensor,
        batch: torch.Tensor,
        n_batch: int,
        eyes: torch.Tensor | None,
        point_eyes: torch.Tensor | None,
        samples: torch.Tensor,
        lower: torch.Tensor,
        shape: tuple[int, int, int] | None = None,
        feature_points: torch.Tensor | None = None,
    ) -> torch.Tensor:
        """The encoder over the grid of `shape` voxels (default: the config's) from the corner `lower` (3,) [m],
        whose sample points are `samples` (V, S, 3); `feature_points` (N,) bool marks the points that give voxel
        features (default: all; every point counts for visibility). Returns (B, C, *shape)."""
        cfg = self.config
        nx, ny, nz = cfg.grid_shape if shape is None else shape
        n_vox = nx * ny * nz
        dims = torch.tensor([nx, ny, nz], device=points.device)
        if cfg.visibility and point_eyes is not None:
            seen = vis.visibility_grid_per_point(
                points, batch, n_batch, point_eyes.to(points.dtype).reshape(-1, 3), samples, self.centre,
                cfg.visibility_bin, cfg.visibility_margin_m,
            )  # fmt: skip
        elif cfg.visibility:
            eyes = torch.full((n_batch, 3), float("nan")) if eyes is None else eyes.to(points.dtype).reshape(-1, 3)
            seen = vis.visibility_grid(
                points, batch, eyes, samples, self.centre, cfg.visibility_bin, cfg.visibility_margin_m
            )
        cell = (points - lower) / cfg.voxel_size
        idx = torch.floor(cell).long()
        inside = torch.all((idx >= 0) & (idx < dims), dim=1)
        if feature_points is not None:
            inside &= feature_points
        idx, cell, batch = idx[inside], cell[inside], batch[inside]
        offset = 2.0 * (cell - idx.to(cell.dtype) - 0.5)  # in [-1, 1] within the voxel
        feats = self._point_features(offset)
        flat = batch * n_vox + (idx[:, 0] * ny + idx[:, 1]) * nz + idx[:, 2]
        pooled = torch.zeros(n_batch * n_vox, cfg.point_features, dtype=feats.dtype, device=feats.device)
        pooled = pooled.scatter_reduce(
            0, flat[:, None].expand(-1, cfg.point_features), feats, "amax", include_self=True
        )
        count = torch.bincount(flat, minlength=n_batch * n_vox).to(feats.dtype)
        grid = torch.cat([pooled, torch.log1p(count)[:, None]] + ([seen.reshape(-1, 3)] if cfg.visibility else []), 1)
        grid = grid.reshape(n_batch, nx, ny, nz, -1).permute(0, 4, 1, 2, 3).contiguous()
        if torch.is_grad_enabled():
            return self.convs(grid)
        for layer in self.convs:  # without autograd: the same convolutions, about twice as fast
            grid = conv3d_by_slices(grid, layer) if isinstance(layer, nn.Conv3d) else layer(grid)
        return grid.contiguous()

    def _forward_active(
        self,
        points: torch.Tensor,
        batch: torch.Tensor,
        n_batch: int,
        eyes: torch.Tensor | None,
        point_eyes: torch.Tensor | None,
    ) -> torch.Tensor:
        """forward() with `active_margin` >= 0: each cloud encoded over its own active box (see the config),
        placed into a zero grid (B, C, nx, ny, nz)."""
        cfg = self.config
        nx, ny, nz = cfg.grid_shape
        out = torch.zeros(n_batch, cfg.channels, nx, ny, nz, dtype=points.dtype, device=points.device)
        idx = torch.floor((points - self.bounds_min) / cfg.voxel_size).long()
        floor = float("-inf") if cfg.floor_m is None else cfg.floor_m
        solid = torch.all((idx >= 0) & (idx < self.grid_dims), dim=1) & (points[:, 2] >= floor)
        samples = self.samples.reshape(nx, ny, nz, *self.samples.shape[1:])
        for b in range(n_batch):
            mine = batch == b
            cells, counts = torch.unique(idx[mine & solid], dim=0, return_counts=True)
            cells = cells[counts >= cfg.active_min_points]
            if not len(cells):
                continue  # nothing above the floor: no features anywhere
            lo = (cells.amin(0) - cfg.active_margin).clamp_min(0)
            hi = torch.minimum(cells.amax(0) + cfg.active_margin + 1, self.grid_dims)
            (x0, y0, z0), (x1, y1, z1) = lo.tolist(), hi.tolist()
            sub = samples[x0:x1, y0:y1, z0:z1].reshape(-1, *self.samples.shape[1:])
            mine_eyes = None if eyes is None else eyes.reshape(-1, 3)[b : b + 1]
            mine_point_eyes = None if point_eyes is None else point_eyes.reshape(-1, 3)[mine]
            pts = points[mine]
            out[b, :, x0:x1, y0:y1, z0:z1] = self._encode_grid(
                pts, torch.zeros(len(pts), dtype=torch.long, device=pts.device), 1, mine_eyes, mine_point_eyes,
                sub, self.bounds_min + lo.to(pts.dtype) * cfg.voxel_size, (x1 - x0, y1 - y0, z1 - z0),
                pts[:, 2] >= floor,
            )[0]  # fmt: skip
        return out

    def _point_features(self, offset: torch.Tensor) -> torch.Tensor:
        """point_mlp of offsets (N, 3) -> (N, point_features). Without autograd, the first layer (3 inputs) is
        three broadcast multiply-adds: the same numbers, faster than a matrix product this thin."""
        if torch.is_grad_enabled():
            return self.point_mlp(offset)
        first, second = cast(nn.Linear, self.point_mlp[0]), self.point_mlp[2]
        w = first.weight.T  # (3, hidden)
        h = torch.addcmul(first.bias, offset[:, :1], w[0])
        h = torch.addcmul(h, offset[:, 1:2], w[1])
        h = torch.addcmul(h, offset[:, 2:3], w[2])
        return torch.relu_(second(torch.relu_(h)))

    def encode(self, points: np.ndarray | torch.Tensor, eye: np.ndarray | None = None) -> SceneEmbedding:
        """Embedding of one cloud (N, 3) [m] in `world` seen from the camera origin `eye` [m] in `world`, if known.

        eye: None (unknown), (3,) the one camera's optical centre, or (N, 3) the origin of each point (a cloud
        fused from several cameras; NaN rows: unknown). Per-point origins that are all the same finite row give
        exactly the (3,) result.
        Raises:
            ValueError: eye is neither (3,) nor (N, 3).
        """
        p = torch.as_tensor(np.asarray(points, dtype=np.float32) if not torch.is_tensor(points) else points)
        p = p.reshape(-1, 3).to(self.bounds_min.device)
        if eye is None:
            return SceneEmbedding(self.forward(p)[0], self.config)
        e = np.asarray(eye.detach().cpu() if torch.is_tensor(eye) else eye, dtype=np.float32)
        if e.size == 3:
            return SceneEmbedding(self.forward(p, eyes=torch.as_tensor(e.reshape(1, 3)))[0], self.config)
        if e.shape != (len(p), 3):
            raise ValueError(f"eye: expected shape (3,) or ({len(p)}, 3) for {len(p)} points, got {e.shape}")
        single = single_origin(e)
        if single is not None:  # one camera: the (3,) computation, bit for bit
            return SceneEmbedding(self.forward(p, eyes=torch.as_tensor(single.reshape(1, 3)))[0], self.config)
        return SceneEmbedding(self.forward(p, point_eyes=torch.as_tensor(e))[0], self.config)


def single_origin(origins: np.ndarray) -> np.ndarray | None:
    """The one origin (3,) shared by every row of origins (N, 3) when they are all the same finite point (N > 0),
    else None."""
    o = np.asarray(origins).reshape(-1, 3)
    if not len(o) or not np.all(np.isfinite(o)) or not np.all(o == o[0]):
        return None
    return o[0].copy()


def conv3d_by_slices(x: torch.Tensor, conv: nn.Conv3d) -> torch.Tensor:
    """conv(x) for a 3x3x3 Conv3d (stride 1, padding 1, no dilation or groups) on x (B, C, D, H, W), computed as
    one 2D convolution over the B*D slices, each slice stacked with its two neighbours (3C channels): the same
    sums in another order. torch's CPU conv3d (slow_conv3d) is about half as fast as its oneDNN conv2d at the
    encoder's sizes. Returns (B, O, D, H, W), not contiguous."""
    same_size = conv.kernel_size == (3, 3, 3) and conv.padding == (1, 1, 1) and conv.padding_mode == "zeros"
    if not same_size or conv.stride != (1, 1, 1) or conv.dilation != (1, 1, 1) or conv.groups != 1:
        return conv(x)
    b, c, d, h, w = x.shape
    padded = F.pad(x, (0, 0, 0, 0, 1, 1))
    slabs = torch.cat([padded[:, :, k : k + d] for k in range(3)], 1)  # (B, 3C, D, H, W): channel k * C + c
    slices = slabs.permute(0, 2, 1, 3, 4).reshape(b * d, 3 * c, h, w)
    weight = conv.weight.permute(0, 2, 1, 3, 4).reshape(conv.out_channels, 3 * c, 3, 3)
    out = F.conv2d(slices, weight, conv.bias, padding=1)  # (B * D, O, H, W)
    return out.reshape(b, d, -1, h, w).permute(0, 2, 1, 3, 4)

"""What the camera saw of each voxel: free space in front of the observed surfaces, and space hidden behind them.

A depth camera's cloud says more than where surfaces are: the ray to each point crossed free space, and the
space behind the point is unknown (often the rest of the object). Given the camera's origin, the cloud's
points are binned by direction (a tangent-plane grid around the line from the camera to the workspace
centre) keeping the nearest range per bin, the bins are min-filtered over 3 x 3 to close the gaps between
sparse points, and 2 x 2 x 2 sample points per voxel are compared with the range of their bin:

- free: nearer than the surface by more than the margin (seen through);
- hidden: farther than the surface by more than the margin (occluded by it).

A sample in a direction without any return (a ray that left the crop box, or pixels that were removed, such
as the robot's) or outside the direction grid is neither: unknown.

The encoder appends three channels per voxel: the fraction of free samples, the fraction of hidden samples,
and 1 (0 for a cloud whose camera origin is unknown: then all three are 0).
"""

from __future__ import annotations

import torch
import torch.nn.functional as F

TAN_RANGE = 1.5
"""half-width of the tangent-plane direction grid (|tan| of the angle off the camera-to-centre line)"""
NO_RETURN = 1.0e4
"""range [m] standing for a bin without any point"""
CHANNELS = 3


def sub_voxel_points(bounds_min: torch.Tensor, voxel_size: float, grid: tuple[int, int, int]) -> torch.Tensor:
    """(V, 8, 3) float32 sample points [m] at the quarter offsets of every voxel, x-major voxel order."""
    nx, ny, nz = grid
    idx = torch.stack(torch.meshgrid(torch.arange(nx), torch.arange(ny), torch.arange(nz), indexing="ij"), -1)
    centres = bounds_min + (idx.reshape(-1, 3).to(torch.float32) + 0.5) * voxel_size
    corners = torch.tensor([[i, j, k] for i in (-1, 1) for j in (-1, 1) for k in (-1, 1)], dtype=torch.float32)
    return centres[:, None, :] + corners * (voxel_size / 4)


def _frames(eyes: torch.Tensor, target: torch.Tensor) -> torch.Tensor:
    """(B, 3, 3) rows: right, down, forward unit vectors of a view from eyes (B, 3) towards target (3,)."""
    fwd = F.normalize(target - eyes, dim=-1)
    up = torch.tensor([0.0, 0.0, 1.0], dtype=eyes.dtype).expand_as(fwd)
    right = torch.linalg.cross(fwd, up)
    vertical = right.norm(dim=-1, keepdim=True) < 1e-6
    right = torch.where(vertical, torch.tensor([0.0, -1.0, 0.0], dtype=eyes.dtype).expand_as(fwd), right)
    right = F.normalize(right, dim=-1)
    return torch.stack([right, torch.linalg.cross(fwd, right), fwd], 1)


def _project(rel: torch.Tensor, frames: torch.Tensor, bin_tan: float, n_bins: int) -> tuple[torch.Tensor, torch.Tensor]:
    """Bin index (...,) (-1 outside the grid) and range (...,) [m] of offsets rel (B, ..., 3) from the eyes."""
    cam = torch.einsum("bij,b...j->b...i", frames, rel)
    depth = cam[..., 2]
    ok = depth > 0.05
    tan = cam[..., :2] / depth.clamp_min(0.05)[..., None]
    cell = torch.floor((tan + TAN_RANGE) / bin_tan).long()
    ok &= torch.all((cell >= 0) & (cell < n_bins), dim=-1)
    flat = torch.where(ok, cell[..., 0] * n_bins + cell[..., 1], torch.full_like(cell[..., 0], -1))
    return flat, rel.norm(dim=-1)


def visibility_grid(
    points: torch.Tensor,
    batch: torch.Tensor,
    eyes: torch.Tensor,
    samples: torch.Tensor,
    target: torch.Tensor,
    bin_tan: float,
    margin: float,
) -> torch.Tensor:
    """Visibility channels (B, V, 3) per voxel: fraction free, fraction hidden, and whether the origin is known.

    Args:
        points: (N, 3) cloud points [m] in `world` of all clouds together.
        batch: (N,) int64 cloud index of each point.
        eyes: (B, 3) camera origins [m] in `world`; a row with a NaN means unknown (its channels are all 0).
        samples: (V, S, 3) sample points [m] per voxel (sub_voxel_points).
        target: (3,) point [m] the direction grid is centred on (the workspace centre).
        bin_tan: bin width of the direction grid, in tangent units (about radians near its centre).
        margin: [m] a sample within this range of its bin's surface is neither free nor hidden.
    """
    n_b, (n_v, n_s) = len(eyes), samples.shape[:2]
    known = torch.isfinite(eyes).all(-1)
    safe_eyes = torch.where(known[:, None], eyes, target.expand_as(eyes) + torch.tensor([0.0, 0.0, 1.0]))
    frames = _frames(safe_eyes, target)
    n_bins = int(round(2 * TAN_RANGE / bin_tan))
    flat, rng = _project((points - safe_eyes[batch])[:, None, :], frames[batch], bin_tan, n_bins)
    flat, rng = flat[:, 0], rng[:, 0]
    keep = flat >= 0
    depth = torch.full((n_b * n_bins * n_bins,), NO_RETURN, dtype=points.dtype)
    depth = depth.scatter_reduce(0, (batch * n_bins * n_bins + flat)[keep], rng[keep], "amin", include_self=True)
    depth = -F.max_pool2d(-depth.reshape(n_b, 1, n_bins, n_bins), 3, 1, 1).reshape(n_b, -1)
    s_flat, s_rng = _project(samples[None] - safe_eyes[:, None, None, :], frames, bin_tan, n_bins)  # (B, V, S)
    surface = torch.gather(depth, 1, s_flat.clamp_min(0).reshape(n_b, -1)).reshape(n_b, n_v, n_s)
    seen = (s_flat >= 0) & (surface < NO_RETURN)
    free = ((s_rng < surface - margin) & seen).to(points.dtype).mean(-1)
    hidden = ((s_rng > surface + margin) & seen).to(points.dtype).mean(-1)
    out = torch.stack([free, hidden, torch.ones_like(free)], -1)
    return out * known[:, None, None].to(out.dtype)

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

Several cameras (a fused cloud with one origin per point, :func:`visibility_grid_per_point`): the points are
grouped by origin (one group per camera), each group is binned and compared as above from its own origin, and
the sub-voxel samples combine per sample, like space carving:

- free: free for at least one camera (some ray passed through it);
- hidden: seen by at least one camera (a return in its direction) and hidden for every camera that sees it,
  so a sample one camera sees free or on a surface is not hidden;
- unknown: seen by no camera.

The voxel's channels are then the fractions of free and hidden samples, as with one camera, so each is at least
the best single camera's free fraction and at most the smallest hidden fraction among the cameras seeing the
voxel. Points whose origin is unknown (a NaN row) still occupy their voxels but see nothing; the third channel
is 1 for a cloud with at least one known origin. With one distinct origin per cloud the results are bit-identical
to :func:`visibility_grid` with that origin.
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


def _sample_states(
    points: torch.Tensor,
    group: torch.Tensor,
    eyes: torch.Tensor,
    samples: torch.Tensor,
    target: torch.Tensor,
    bin_tan: float,
    margin: float,
) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
    """Per view and sample: (free, hidden, seen), each (G, V, S) bool.

    Args:
        points: (N, 3) points [m] in `world`; group: (N,) int64 view index of each point.
        eyes: (G, 3) finite view origins [m] in `world`.
        samples, target, bin_tan, margin: as in :func:`visibility_grid`.
    """
    n_g, (n_v, n_s) = len(eyes), samples.shape[:2]
    frames = _frames(eyes, target)
    n_bins = int(round(2 * TAN_RANGE / bin_tan))
    flat, rng = _project((points - eyes[group])[:, None, :], frames[group], bin_tan, n_bins)
    flat, rng = flat[:, 0], rng[:, 0]
    keep = flat >= 0
    depth = torch.full((n_g * n_bins * n_bins,), NO_RETURN, dtype=points.dtype)
    depth = depth.scatter_reduce(0, (group * n_bins * n_bins + flat)[keep], rng[keep], "amin", include_self=True)
    depth = -F.max_pool2d(-depth.reshape(n_g, 1, n_bins, n_bins), 3, 1, 1).reshape(n_g, -1)
    s_flat, s_rng = _project(samples[None] - eyes[:, None, None, :], frames, bin_tan, n_bins)  # (G, V, S)
    surface = torch.gather(depth, 1, s_flat.clamp_min(0).reshape(n_g, -1)).reshape(n_g, n_v, n_s)
    seen = (s_flat >= 0) & (surface < NO_RETURN)
    return (s_rng < surface - margin) & seen, (s_rng > surface + margin) & seen, seen


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
    known = torch.isfinite(eyes).all(-1)
    safe_eyes = torch.where(known[:, None], eyes, target.expand_as(eyes) + torch.tensor([0.0, 0.0, 1.0]))
    free, hidden, _ = _sample_states(points, batch, safe_eyes, samples, target, bin_tan, margin)
    free, hidden = free.to(points.dtype).mean(-1), hidden.to(points.dtype).mean(-1)
    out = torch.stack([free, hidden, torch.ones_like(free)], -1)
    return out * known[:, None, None].to(out.dtype)


def unique_rows(key: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """torch.unique(key, dim=0, return_inverse=True) for rows key (N, D) that come in runs of equal rows (a fused
    cloud is its views one after the other): the sorted distinct rows (U, D) and each row's index (N,) among
    them. The rows that start a run go through torch.unique, whose row sort costs tens of milliseconds on a
    fused cloud of 50,000 points; the runs then take their row's index. Any order is right, runs only make it
    fast."""
    if len(key) < 2:
        return torch.unique(key, dim=0, return_inverse=True)
    starts = torch.ones(len(key), dtype=torch.bool)
    starts[1:] = (key[1:] != key[:-1]).any(-1)
    first = torch.nonzero(starts).squeeze(1)  # (R,) row where each run starts
    views, run_index = torch.unique(key[first], dim=0, return_inverse=True)
    lengths = torch.diff(first, append=torch.tensor([len(key)]))
    return views, run_index.repeat_interleave(lengths)


def visibility_grid_per_point(
    points: torch.Tensor,
    batch: torch.Tensor,
    n_batch: int,
    point_eyes: torch.Tensor,
    samples: torch.Tensor,
    target: torch.Tensor,
    bin_tan: float,
    margin: float,
) -> torch.Tensor:
    """Visibility channels (B, V, 3) of clouds fused from several cameras, one origin per point.

    The points of each cloud are grouped by their origin (one group per camera) and the cameras' views are
    combined per sample as the module docstring says.

    Args:
        points: (N, 3) cloud points [m] in `world` of all clouds together.
        batch: (N,) int64 cloud index of each point.
        n_batch: number of clouds B.
        point_eyes: (N, 3) origin [m] in `world` of the camera that saw each point; a row with a NaN: unknown.
        samples, target, bin_tan, margin: as in :func:`visibility_grid`.
    """
    n_v, n_s = samples.shape[:2]
    known = torch.isfinite(point_eyes).all(-1)
    pts, bat, eye = points[known], batch[known], point_eyes[known].to(points.dtype)
    key = torch.cat([bat[:, None].to(eye.dtype), eye], 1)
    views, group = unique_rows(key)  # (G, 4): cloud index and origin
    out = torch.zeros(n_batch, n_v, 3, dtype=points.dtype)
    if not len(views):
        return out
    free, hidden, seen = _sample_states(pts, group, views[:, 1:], samples, target, bin_tan, margin)
    view_cloud = views[:, 0].long()
    for b in torch.unique(view_cloud).tolist():
        mine = view_cloud == b
        f, h, s = free[mine], hidden[mine], seen[mine]
        free_b = f.any(0)
        hidden_b = s.any(0) & ~(s & ~h).any(0)
        out[b, :, 0] = free_b.to(points.dtype).mean(-1)
        out[b, :, 1] = hidden_b.to(points.dtype).mean(-1)
        out[b, :, 2] = 1.0
    return out

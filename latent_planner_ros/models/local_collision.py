"""A local collision predictor: each link's p(collision) from the cloud points next to it, seen in its own frame.

The grid network (collision_net.py) encodes a box of the scene into 10 cm voxels and reads it at the links'
points; shelf boards and cage bars 1-2 cm thick are below what such a grid holds, and the box ends before the
arm's reach does. This network looks at no box: for each link it takes the K nearest cloud points to A anchors
spread along the link (within radius_m), expresses them in the link's frame, and gives each point

- its position in the link frame (3, over 0.1 m),
- its signed distance to the link's convex hull (1, over 5 cm; a lower bound from `planes` of the hull's
  facets, negative inside),
- the direction from the point to the camera that saw it, in the link frame (3; zero if unknown),

to a shared point MLP, max-pooled per link, then a head with the link's embedding and the smallest hull
distance gives the link's logit. Being local and in the link's frame it carries over to furniture it has not
seen (what a link touches looks alike everywhere), and it is differentiable in the link poses, so the planner's
gradients flow from it through the forward kinematics into the latent.

Finding the points is not differentiable (a KD-tree, `gather_points`); the features are.

    net = LocalCollisionNet(LocalCollisionConfig())
    nb = Neighbourhoods.of(cloud, eyes, frames_np, net.config)   # frames (B, L, 4, 4) [m] of LABEL_LINKS
    logits = net(frames, nb)                                       # (B, L)
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import asdict, dataclass

import numpy as np
import torch
from scipy.spatial import cKDTree
from torch import nn

from latent_planner_ros.data.link_geometry import LABEL_LINKS, link_geometry
from latent_planner_ros.robot.link_hulls import link_hull_planes
from latent_planner_ros.robot.panda import LINK_FRAMES

POSITION_SCALE_M = 0.1
"""point positions are given over this length [m]"""
HULL_SCALE_M = 0.05
"""hull distances are given over this length [m], clipped to [-2, 4] units"""
FEATURES = 7
"""per point: position (3), hull distance (1), direction to the camera (3)"""


@dataclass(frozen=True)
class LocalCollisionConfig:
    """Architecture of a LocalCollisionNet.

    Attributes:
        anchors: anchor points per link, along its principal axis.
        k: nearest cloud points per anchor.
        radius_m: points farther than this [m] from an anchor are not taken.
        planes: hull facets per link for the hull distance (spread over the normals' directions).
        hidden: width of the point MLP's first layer (its output and the head: twice that).
        link_embedding: size of each link's learned embedding.
    """

    anchors: int = 3
    k: int = 8
    radius_m: float = 0.12
    planes: int = 48
    hidden: int = 64
    link_embedding: int = 16

    def to_dict(self) -> dict:
        return asdict(self)

    @classmethod
    def from_dict(cls, d: dict) -> LocalCollisionConfig:
        return cls(**{k: d[k] for k in cls.__dataclass_fields__ if k in d})


def _spread_planes(planes: np.ndarray, n: int) -> np.ndarray:
    """n of the hull's planes (F, 4) whose normals spread over the directions (farthest-point on the normals)."""
    if len(planes) <= n:
        return planes
    chosen = [0]
    dist = 1.0 - planes[:, :3] @ planes[0, :3]
    for _ in range(n - 1):
        chosen.append(int(dist.argmax()))
        dist = np.minimum(dist, 1.0 - planes[:, :3] @ planes[chosen[-1], :3])
    return planes[chosen]


def hull_planes(n: int) -> np.ndarray:
    """(L, n, 4) planes (unit outward normal, offset) of each LABEL_LINKS link's hull in its frame; links with
    fewer facets are padded with a plane no point reaches (0, 0, 0, -10)."""
    hulls = link_hull_planes()
    out = np.tile(np.array([0.0, 0.0, 0.0, -10.0]), (len(LABEL_LINKS), n, 1))
    for i, name in enumerate(LABEL_LINKS):
        chosen = _spread_planes(hulls[LINK_FRAMES.index(name)], n)
        out[i, : len(chosen)] = chosen
    return out


@dataclass
class Neighbourhoods:
    """The cloud points next to each link of B configurations: points (B, L, N, 3) [m] in `world`, the origin
    of the camera that saw each (B, L, N, 3) [m] (NaN: unknown), and which are real (B, L, N) bool; N = A * k."""

    points: torch.Tensor
    eyes: torch.Tensor
    valid: torch.Tensor

    @classmethod
    def of(
        cls,
        tree: cKDTree | None,
        cloud: np.ndarray,
        eyes: np.ndarray | None,
        frames: np.ndarray,
        anchors: np.ndarray,
        config: LocalCollisionConfig,
        near: Callable[[np.ndarray, float], np.ndarray] | None = None,
    ) -> Neighbourhoods:
        """Gather the k nearest points of cloud (P, 3) [m] (indexed by `tree`, None for an empty cloud) within
        radius_m of each anchor (L, A, 3) [m, link frame] at link poses frames (B, L, 4, 4) [m]; eyes (P, 3) [m]
        per point, or None. near(centres (M, 3), radius) -> (M,) bool, if given, is a cheaper test of "a point
        within radius of the centre" (it may say True for more): the tree is asked about those anchors only."""
        b, n_links = frames.shape[:2]
        n = config.anchors * config.k
        if tree is None or not len(cloud):
            z = torch.zeros(b, n_links, n, 3)
            return cls(z, torch.full_like(z, float("nan")), torch.zeros(b, n_links, n, dtype=torch.bool))
        world = np.einsum("blij,laj->blai", frames[..., :3, :3], anchors) + frames[:, :, None, :3, 3]
        flat = world.reshape(-1, 3)
        d = np.full((len(flat), config.k), np.inf)
        idx = np.zeros((len(flat), config.k), dtype=np.intp)
        ask = np.arange(len(flat)) if near is None else np.flatnonzero(near(flat, config.radius_m * (1 + 1e-6)))
        if len(ask):
            found_d, found_i = tree.query(flat[ask], k=config.k, distance_upper_bound=config.radius_m)
            d[ask] = np.asarray(found_d).reshape(len(ask), config.k)
            idx[ask] = np.asarray(found_i).reshape(len(ask), config.k)
        valid = np.isfinite(d.reshape(b, n_links, n))
        idx = np.where(valid, idx.reshape(b, n_links, n), 0)
        pts = cloud[idx]
        eye = eyes[idx] if eyes is not None else np.full(pts.shape, np.nan, dtype=np.float32)
        return cls(
            torch.as_tensor(pts, dtype=torch.float32),
            torch.as_tensor(eye, dtype=torch.float32),
            torch.as_tensor(valid),
        )


class LocalCollisionNet(nn.Module):
    """Per-link collision logits from each link's neighbourhood in the cloud (module docstring)."""

    anchors: torch.Tensor
    """(L, A, 3) anchor points [m] in the link frames"""
    planes: torch.Tensor
    """(L, P, 4) hull planes of each link in its frame (hull_planes)"""

    def __init__(self, config: LocalCollisionConfig | None = None):
        super().__init__()
        self.config = c = config or LocalCollisionConfig()
        n_links = len(LABEL_LINKS)
        self.register_buffer("anchors", torch.as_tensor(link_geometry().axis_points(c.anchors), dtype=torch.float32))
        self.register_buffer("planes", torch.as_tensor(hull_planes(c.planes), dtype=torch.float32))
        h = c.hidden
        self.point_mlp = nn.Sequential(nn.Linear(FEATURES, h), nn.ReLU(), nn.Linear(h, 2 * h), nn.ReLU())
        self.link_embedding = nn.Embedding(n_links, c.link_embedding)
        self.head = nn.Sequential(
            nn.Linear(2 * h + c.link_embedding + 1, 2 * h), nn.ReLU(), nn.Linear(2 * h, h), nn.ReLU(), nn.Linear(h, 1)
        )

    def anchors_np(self) -> np.ndarray:
        """(L, A, 3) anchors [m] in the link frames."""
        return self.anchors.numpy().astype(np.float64)

    def features(self, frames: torch.Tensor, nb: Neighbourhoods) -> tuple[torch.Tensor, torch.Tensor]:
        """Point features (B, L, N, FEATURES) and hull distances (B, L, N) [scaled] of nb at link poses frames
        (B, L, 4, 4) [m]; differentiable in frames."""
        rot, t = frames[..., :3, :3].float(), frames[..., :3, 3].float()
        local = torch.einsum("blji,blnj->blni", rot, nb.points - t[:, :, None])  # R^T (p - t)
        planes = self.planes  # (L, P, 4)
        hull = (torch.einsum("blni,lpi->blnp", local, planes[..., :3]) + planes[None, :, None, :, 3]).amax(-1)
        hull = (hull / HULL_SCALE_M).clamp(-2.0, 4.0)
        to_eye = nb.eyes - nb.points
        known = torch.isfinite(to_eye).all(-1, keepdim=True)
        to_eye = torch.where(known, to_eye, torch.zeros_like(to_eye))
        view = torch.einsum("blji,blnj->blni", rot, to_eye)
        view = view / view.norm(dim=-1, keepdim=True).clamp_min(1e-6)
        x = torch.cat([local / POSITION_SCALE_M, hull[..., None], view], -1)
        return x, hull

    def forward(self, frames: torch.Tensor, nb: Neighbourhoods) -> torch.Tensor:
        """Per-link logits (B, L) at link poses frames (B, L, 4, 4) [m] with their neighbourhoods nb."""
        x, hull = self.features(frames, nb)
        b, n_links, n, _ = x.shape
        valid = nb.valid
        width = 2 * self.config.hidden
        pooled = torch.full((b, n_links, n, width), -1e4, dtype=x.dtype)
        if bool(valid.any()):
            pooled = pooled.index_put((valid,), self.point_mlp(x[valid]))
        pooled = pooled.amax(2)
        pooled = torch.where(valid.any(2, keepdim=True), pooled, torch.zeros_like(pooled))
        hull_min = torch.where(valid, hull, torch.full_like(hull, 4.0)).amin(2, keepdim=True)
        emb = self.link_embedding.weight[None].expand(b, -1, -1)
        return self.head(torch.cat([pooled, emb, hull_min], -1))[..., 0]

"""Geometric collision backend: the arm as spheres against the observed point cloud.

The differentiable cost is each sphere's clearance to its nearest observed point (`distance: nearest`, a KD-tree
query per step, exact, up to `cost_range`), or samples a Euclidean distance field of the cloud (`distance:
field`: voxel grid, trilinear interpolation; a field over the arm's whole reach costs tens of ms per scene); the
hard check is exact (ball_query.py: an occupancy prefilter, then a KD-tree), so no checked
state has an observed point inside any of the arm's (conservative) spheres, or, with `exact_margin`, no observed
point inside a sphere and within that margin of the link's convex hull: the spheres find the candidates, the
hulls decide. With `exact_margin`, an occupied voxel wholly inside one of a link's inner balls (balls inside its
hull, robot/link_hulls.hull_inner_balls) refuses a configuration before any KD-tree query; the answers are the same.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch
import torch.nn.functional as F
from scipy.ndimage import distance_transform_edt

from latent_planner_ros.planning.ball_query import BallQuery, finite_rows
from latent_planner_ros.planning.collision_backend import BackendDefaults
from latent_planner_ros.robot.link_hulls import hull_cover_spheres, hull_inner_balls, link_hull_planes, plane_distance
from latent_planner_ros.robot.panda import LINK_FRAMES
from latent_planner_ros.robot.spheres import panda_spheres
from latent_planner_ros.robot.torch_fk import TorchFK


@dataclass(frozen=True)
class GeometricBackendConfig:
    resolution: float = 0.02
    """distance-field voxel size [m]"""
    bounds_min: tuple[float, float, float] = (-1.0, -1.0, -0.1)
    """lower corner of the distance field [m]"""
    bounds_max: tuple[float, float, float] = (1.0, 1.0, 1.3)
    """upper corner of the distance field [m]"""
    distance: str = "nearest"
    """the cost's clearance: "nearest" (to the nearest observed point, a KD-tree query) or "field" (a distance
    field of `resolution` over the bounds, computed per scene)"""
    cost_range: float = 0.15
    """[m] "nearest": clearances beyond this count as this (the cost is flat there: sigmoid((margin - 0.15) /
    temperature) < 1e-6)"""
    margin: float = 0.01
    """clearance [m] below which the cost starts to rise"""
    temperature: float = 0.01
    """width [m] of the sigmoid from clearance to probability"""
    floor_z: float | None = 0.015
    """points below this height [m] are the table, which the planners check exactly (a half-space in their
    self/table check), not obstacles: the same rule as the OMPL baseline's `min_z`, so noisy table points do not
    push the arm's links 2 cm off the table top; None: every point is an obstacle"""
    check_margin: float = 0.0
    """extra clearance [m] required by the hard check"""
    exact_margin: float | None = 0.01
    """None: the hard check refuses every observed point inside a sphere of the sphere model; else a configuration
    is refused when an observed point lies within this distance [m] of the convex hull of a link's collision
    geometry (robot/link_hulls.py; spheres covering the hulls grown by this margin find the candidates), so that
    the sphere model's slack does not close gaps of 1-2 cm (goals in a shelf slot or a bin) and its gaps (parts
    of the hulls outside its spheres) let nothing through"""

    def __post_init__(self) -> None:
        if self.distance not in ("nearest", "field"):
            raise ValueError(f"distance must be 'nearest' or 'field', got {self.distance!r}")
        if not self.cost_range > 0:
            raise ValueError(f"cost_range must be positive, got {self.cost_range!r}")


HULL_FEW_PLANES = 24
"""planes of each link hull tried first in the hull test (directions spread over the sphere)"""
EINSUM_BLAS_ROWS = 8
"""the sphere centres of more configurations than this go through numpy's optimised einsum (BLAS), faster there
and slower for a few"""


def _spread(normals: np.ndarray, k: int) -> np.ndarray:
    """Indices of k rows of normals (F, 3) with directions spread apart (greedy farthest point)."""
    chosen = [0]
    dist = 1.0 - normals @ normals[0]
    for _ in range(min(k, len(normals)) - 1):
        chosen.append(int(np.argmax(dist)))
        dist = np.minimum(dist, 1.0 - normals @ normals[chosen[-1]])
    return np.asarray(chosen)


class GeometricBackend(BackendDefaults):
    name = "geometric"

    def __init__(self, config: GeometricBackendConfig | None = None):
        self.config = config or GeometricBackendConfig()
        self.spheres = panda_spheres()
        moving = self.spheres.link != LINK_FRAMES.index("panda_link0")  # the base stands on the table
        self._idx = torch.as_tensor(np.flatnonzero(moving))
        self._radius = torch.as_tensor(self.spheres.radius[moving], dtype=torch.float32)
        self._fk = TorchFK()
        # the hard check in float64 numpy: each check sphere's link, homogeneous centre (S, 4) and radius [m]; with
        # exact_margin, spheres covering the link hulls grown by that margin (the hull test decides), else the
        # sphere model's moving spheres
        if self.config.exact_margin is None:
            link, centre, radius = self.spheres.link[moving], self.spheres.centre[moving], self.spheres.radius[moving]
        else:
            link, centre, radius = hull_cover_spheres()
            radius = radius + self.config.exact_margin
        self._sphere_link = link
        self._sphere_centre = np.concatenate([centre, np.ones((len(link), 1))], 1)
        self._check_radius = np.maximum(radius + self.config.check_margin, 0.0)
        # per link, a ball holding all of its check spheres: link index, homogeneous centre (L, 4), radius [m]
        self._bound_link, self._sphere_bound = np.unique(link, return_inverse=True)
        bound_centre = np.array([centre[link == lk].mean(axis=0) for lk in self._bound_link])
        reach = np.linalg.norm(centre - bound_centre[self._sphere_bound], axis=1) + self._check_radius
        self._bound_radius = np.array([reach[link == lk].max() for lk in self._bound_link])
        self._bound_centre = np.concatenate([bound_centre, np.ones((len(bound_centre), 1))], 1)
        self._hulls = link_hull_planes()
        self._hull_few = {lk: planes[_spread(planes[:, :3], HULL_FEW_PLANES)] for lk, planes in self._hulls.items()}
        # per moving sphere, the radius [m] of the ball about its centre that lies inside its link's hull (0 if the
        # centre is outside it): a point that close to the centre is inside the hull
        self._core = np.array([
            max(0.0, -plane_distance(self._hulls[lk], c[None, :3])[0])
            for lk, c in zip(self._sphere_link, self._sphere_centre, strict=True)
        ])  # fmt: skip
        # balls inside the hulls (link index, homogeneous centre (I, 4), radius + exact_margin [m]): an observed
        # point in one refuses the configuration before any nearest-point search
        inner_link, inner_centre, inner_radius = hull_inner_balls()
        self._inner_link = inner_link
        self._inner_centre = np.concatenate([inner_centre, np.ones((len(inner_link), 1))], 1)
        self._inner_reach = inner_radius + (self.config.exact_margin or 0.0)
        self._lo = np.asarray(self.config.bounds_min, dtype=float)
        self._hi = np.asarray(self.config.bounds_max, dtype=float)
        self.set_scene(np.zeros((0, 3)))

    def set_check_cloud(self, cloud: np.ndarray) -> np.ndarray:
        """Use cloud (N, 3) [m] for the hard check only (no distance field); returns its finite points."""
        cloud = np.asarray(cloud, dtype=float).reshape(-1, 3)
        cloud = cloud[finite_rows(cloud)]
        if self.config.floor_z is not None:
            cloud = cloud[cloud[:, 2] >= self.config.floor_z]
        self.cloud = cloud
        self._balls = BallQuery(cloud)
        return cloud

    def set_scene(self, cloud: np.ndarray, origin: np.ndarray | None = None) -> None:
        """Use cloud (N, 3) [m] for both the cost (distance field) and the hard check (origin, (3,) or (N, 3) per
        point, is not used: only observed points are obstacles here)."""
        cloud = self.set_check_cloud(cloud)
        if self.config.distance == "nearest":
            return
        res = self.config.resolution
        shape = np.ceil((self._hi - self._lo) / res).astype(int) + 1
        occ = np.zeros(shape, dtype=bool)
        inside = cloud[np.all((cloud >= self._lo) & (cloud <= self._hi), axis=1)]
        if len(inside):
            ijk = np.round((inside - self._lo) / res).astype(int)
            occ[ijk[:, 0], ijk[:, 1], ijk[:, 2]] = True
            dist = distance_transform_edt(~occ) * res
        else:
            dist = np.full(shape, 10.0)
        # grid_sample wants (N, C, D, H, W) indexed [z, y, x]; our array is [x, y, z]
        self._field = torch.as_tensor(dist.transpose(2, 1, 0)[None, None], dtype=torch.float32)

    def _centres(self, q: torch.Tensor, frames: torch.Tensor | None = None) -> torch.Tensor:
        frames = self._fk(q.float()) if frames is None else frames.float()
        return self.spheres.centres_world(frames)[:, self._idx]  # (B, S, 3)

    def clearance(self, q: torch.Tensor, frames: torch.Tensor | None = None) -> torch.Tensor:
        """Distance-field clearance [m] of every moving sphere, (B, S) (negative = penetrating); frames
        (B, len(LINK_FRAMES), 4, 4) [m]: q's link frames if already computed (TorchFK), else computed here."""
        c = self._centres(q, frames)
        if self.config.distance == "nearest":
            return self._nearest_clearance(c)
        lo = torch.as_tensor(self._lo, dtype=c.dtype)
        hi = torch.as_tensor(self._hi, dtype=c.dtype)
        grid = (2.0 * (c - lo) / (hi - lo) - 1.0).view(1, c.shape[0], c.shape[1], 1, 3)
        d = F.grid_sample(self._field, grid, mode="bilinear", padding_mode="border", align_corners=True)
        return d.view(c.shape[0], c.shape[1]) - self._radius

    def _nearest_clearance(self, c: torch.Tensor) -> torch.Tensor:
        """Clearance (B, S) [m] of spheres centred at c (B, S, 3) [m] to their nearest observed point (at most
        cost_range); differentiable in c (the nearest point is held fixed)."""
        far = self.config.cost_range
        if not len(self.cloud):
            return torch.full(c.shape[:2], far, dtype=c.dtype) - self._radius
        flat = c.detach().reshape(-1, 3).numpy().astype(float)
        dist, idx = self._balls._kdtree().query(flat, distance_upper_bound=far)
        idx = np.asarray(idx)
        near = np.isfinite(dist)
        nearest = np.zeros_like(flat)
        nearest[near] = self.cloud[idx[near]]
        diff = c - torch.as_tensor(nearest, dtype=c.dtype).view_as(c)
        d = torch.sqrt((diff * diff).sum(-1) + 1e-12)
        d = torch.where(torch.as_tensor(near).view(c.shape[:2]), d, torch.full_like(d, far))
        return d - self._radius

    takes_frames = True  # p_collision accepts the link frames of q (AmpLs's FK, shared: one FK per step)

    def p_collision(self, q: torch.Tensor, z: torch.Tensor, frames: torch.Tensor | None = None) -> torch.Tensor:
        """Differentiable p(collision) (B,) of q (B, 7) [rad] from its spheres' clearance (z: not used; frames
        (B, len(LINK_FRAMES), 4, 4) [m]: q's link frames if already computed, differentiable in q)."""
        cfg = self.config
        logits = (cfg.margin - self.clearance(q, frames)) / cfg.temperature
        return torch.sigmoid(logits.max(dim=1).values)

    def link_p_collision(self, q: np.ndarray) -> dict[str, float]:
        """p(collision) of each moving link for one configuration q (7,) [rad]: {link frame name: p}, the cost's
        probability (p_collision) of the link's own spheres (for display, e.g. the view's link colours)."""
        with torch.no_grad():
            clearance = self.clearance(torch.as_tensor(np.asarray(q, dtype=np.float32)[None]))[0].numpy()
        links = self.spheres.link[self._idx.numpy()]
        cfg = self.config
        return {
            LINK_FRAMES[lk]: float(1.0 / (1.0 + np.exp(-(cfg.margin - clearance[links == lk].min()) / cfg.temperature)))
            for lk in np.unique(links)
        }

    def check(self, q: np.ndarray) -> np.ndarray:
        """Hard decision (M,) bool for q (M, 7) [rad]: an observed point closer than radius + check_margin to the
        centre of one of the arm's spheres."""
        return self.check_frames(self._fk.frames_np(np.atleast_2d(q)))

    def check_frames(self, frames: np.ndarray) -> np.ndarray:
        """`check` from the link frames (M, len(LINK_FRAMES), 4, 4) [m] of the configurations (TorchFK.frames_np),
        for callers that need the frames for other checks too."""
        if not len(self.cloud):
            return np.zeros(len(frames), dtype=bool)
        t = frames[:, self._sphere_link, :3, :]  # (M, S, 3, 4)
        big = len(frames) > EINSUM_BLAS_ROWS  # numpy's BLAS path: several times faster for many states
        c = np.einsum("msij,sj->msi", t, self._sphere_centre, optimize=big)  # R c + p, (M, S, 3)
        # one ball per link first (it holds all of the link's check spheres): only links whose ball's box holds a
        # point are asked sphere by sphere (most states of a plan are far from most points); both stages are the
        # occupancy prefilter alone, the KD-tree decides once below
        lc = np.einsum("mlij,lj->mli", frames[:, self._bound_link, :3, :], self._bound_centre, optimize=big)
        near = self._balls.maybe_occupied(lc.reshape(-1, 3), np.tile(self._bound_radius, len(frames)))
        near = near.reshape(lc.shape[:2])[:, self._sphere_bound]  # (M, S): the sphere's link ball may hold a point
        maybe = np.zeros(c.shape[:2], dtype=bool)
        if near.any():
            maybe[near] = self._balls.maybe_occupied(c[near], self._check_radius[np.nonzero(near)[1]])
        bad = ~np.isfinite(lc).all(axis=(1, 2))  # a non-finite configuration is refused
        if bad.any():
            maybe[bad] = False
        if not maybe.any():
            return bad
        if self.config.exact_margin is None:
            hit = np.zeros(c.shape[:2], dtype=bool)
            hit[maybe] = self._balls.occupied(c[maybe], self._check_radius[np.nonzero(maybe)[1]])
            return hit.any(axis=1) | bad
        # sure hits first, without the KD-tree: an occupied voxel wholly inside one of the inner balls (grown by the
        # margin) of a link with candidate spheres refuses the configuration with all of its candidates
        todo = np.flatnonzero(maybe.any(axis=1))
        ic = np.einsum("mlij,lj->mli", frames[todo][:, self._inner_link, :3, :], self._inner_centre)  # (T, I, 3)
        link_cand = np.zeros((len(todo), len(LINK_FRAMES)), dtype=bool)
        mt, st = np.nonzero(maybe[todo])
        link_cand[mt, self._sphere_link[st]] = True
        ask = link_cand[:, self._inner_link]  # (T, I): inner balls of links with candidates
        sure = np.zeros(ask.shape, dtype=bool)
        sure[ask] = self._balls.surely_occupied(ic[ask], np.broadcast_to(self._inner_reach, ask.shape)[ask])
        sure = todo[sure.any(axis=1)]
        maybe[sure] = False
        out = self._hull_hits(frames, c, maybe) if maybe.any() else np.zeros(len(frames), dtype=bool)
        out[sure] = True
        return out | bad

    def _hull_hits(self, frames: np.ndarray, centres: np.ndarray, maybe: np.ndarray) -> np.ndarray:
        """(M,) bool: configurations with an observed point that lies inside one of their spheres marked `maybe`
        (M, S) and within exact_margin of that sphere's link hull; frames (M, F, 4, 4), centres (M, S, 3) [m]."""
        m_idx, s_idx = np.nonzero(maybe)
        # one bounded nearest-point query per candidate sphere: none within its radius, no point inside it; sure
        # hits next: a point within core + margin of a sphere's centre is within margin of the hull, since the ball
        # of radius core about that centre lies inside the hull
        radius = self._check_radius[s_idx]
        nearest, _ = self._balls._kdtree().query(centres[m_idx, s_idx], distance_upper_bound=float(radius.max()))
        nearest = np.asarray(nearest)
        inside = nearest < radius
        m_idx, s_idx, nearest = m_idx[inside], s_idx[inside], nearest[inside]
        out = np.zeros(len(frames), dtype=bool)
        out[m_idx[nearest <= self._core[s_idx] + self.config.exact_margin]] = True
        open_ = ~out[m_idx]
        m_idx, s_idx = m_idx[open_], s_idx[open_]
        if not len(m_idx):
            return out
        lists = self._balls._kdtree().query_ball_point(centres[m_idx, s_idx], self._check_radius[s_idx])
        counts = np.fromiter((len(p) for p in lists), dtype=int, count=len(lists))
        pair = np.repeat(np.arange(len(lists)), counts)
        point = np.concatenate(lists).astype(int) if len(pair) else np.zeros(0, dtype=int)
        # the spheres of a link overlap: test each (configuration, link, point) once
        key = (m_idx[pair].astype(np.int64) * len(LINK_FRAMES) + self._sphere_link[s_idx[pair]]) * len(self.cloud)
        _, first = np.unique(key + point, return_index=True)
        pair, point = pair[first], point[first]
        pts = self.cloud[point]
        link = self._sphere_link[s_idx[pair]]
        tf = frames[m_idx[pair], link]  # (P, 4, 4): each point's link pose
        local = np.einsum("pji,pj->pi", tf[:, :3, :3], pts - tf[:, :3, 3])  # R^T (p - t)
        close = np.zeros(len(pair), dtype=bool)
        margin = self.config.exact_margin
        for lk in np.unique(link):
            sel = np.flatnonzero(link == lk)
            # a few of the hull's planes first: a point beyond one of them by more than the margin is out (exact:
            # the full test's maximum is at least that); the rest take all planes
            few = plane_distance(self._hull_few[lk], local[sel]) <= margin
            sel = sel[few]
            close[sel] = plane_distance(self._hulls[lk], local[sel]) <= margin
        out[m_idx[pair[close]]] = True
        return out

"""Robot configurations to label in a scene: half uniform over the feasible set, half near the objects.

Uniform feasible configurations are almost all free (~99 %); the near half is screened from a larger
uniform candidate set by a cheap proxy distance (link surface points to object surface samples), so the
decision boundary is well covered.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from latent_planner_ros.data.labels import link_poses
from latent_planner_ros.data.link_geometry import link_geometry
from latent_planner_ros.data.obstacle_geometry import sample_surface, surface_area
from latent_planner_ros.data.obstacles import bounding_sphere
from latent_planner_ros.data.scene import Scene


@dataclass(frozen=True)
class QuerySamplerConfig:
    """How many configurations per scene and how "near" is screened."""

    n_uniform: int = 256
    """uniform feasible configurations per scene"""
    n_near: int = 256
    """configurations near the objects per scene"""
    candidates: int = 3000
    """uniform feasible candidates screened for the near set"""
    near_distance: float = 0.05
    """proxy distance [m] below which a candidate counts as near"""
    surface_density: float = 40_000.0
    """object surface samples per square metre for the proxy distance (at least 64 per obstacle)"""


def object_surface_points(scene: Scene, rng: np.random.Generator, density: float = 40_000.0) -> np.ndarray:
    """Points (M, 3) [m] spread over the surfaces of every obstacle of the scene."""
    pts = [sample_surface(o, max(64, int(surface_area(o) * density)), rng) for o in scene.obstacles]
    return np.concatenate(pts) if pts else np.zeros((0, 3))


def proxy_distance(
    scene: Scene, q: np.ndarray, tree: cKDTree, cap: float = 0.1, poses: np.ndarray | None = None
) -> np.ndarray:
    """Smallest distance (N,) [m] from the links' surface points at q (N, 7) to the points in `tree`, capped.

    Links whose bounding sphere is farther than `cap` from every obstacle's bounding sphere are skipped.
    `poses` (N, L, 4, 4) are the link poses of q if already known (see labels.link_poses).
    """
    links = link_geometry()
    poses = link_poses(q) if poses is None else poses
    centres = np.einsum("nlij,lj->nli", poses[..., :3, :3], links.sphere_centres) + poses[..., :3, 3]
    spheres = [bounding_sphere(o) for o in scene.obstacles]
    oc = np.array([c for c, _ in spheres])
    orad = np.array([r for _, r in spheres])
    gap = np.linalg.norm(centres[:, :, None] - oc[None, None], axis=-1) - orad - links.sphere_radii[:, None]
    n_idx, l_idx = np.nonzero(gap.min(-1) < cap)  # sorted by n
    out = np.full(len(poses), cap)
    if len(n_idx):
        pose = poses[n_idx, l_idx]  # (K, 4, 4)
        pts = np.einsum("kij,ksj->ksi", pose[:, :3, :3], links.surface_points[l_idx]) + pose[:, None, :3, 3]
        d, _ = tree.query(pts.reshape(-1, 3), distance_upper_bound=cap)
        d_min = np.asarray(d).reshape(len(n_idx), -1).min(1)
        starts = np.flatnonzero(np.r_[True, n_idx[1:] != n_idx[:-1]])
        out[n_idx[starts]] = np.minimum(np.minimum.reduceat(d_min, starts), cap)
    return out


def sample_query_indices(
    scene: Scene,
    pool: np.ndarray,
    rng: np.random.Generator,
    config: QuerySamplerConfig | None = None,
    pool_poses: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Indices into a pool (P, 7) [rad] of uniform feasible configurations to label in `scene`.

    Returns indices (n_uniform + n_near,) and a mask (same length) of the near ones. `pool_poses`
    (P, L, 4, 4) are the pool's link poses if already known.
    """
    cfg = config or QuerySamplerConfig()
    idx = rng.choice(len(pool), min(len(pool), cfg.n_uniform + cfg.candidates), replace=False)
    uniform, cand = idx[: cfg.n_uniform], idx[cfg.n_uniform :]
    if cfg.n_near == 0:
        return uniform, np.zeros(len(uniform), dtype=bool)
    surface = object_surface_points(scene, rng, cfg.surface_density)
    if len(surface) == 0:
        near = cand[: cfg.n_near]
    else:
        poses = None if pool_poses is None else pool_poses[cand]
        d = proxy_distance(scene, pool[cand], cKDTree(surface), poses=poses)
        close = np.flatnonzero(d < cfg.near_distance)
        if len(close) >= cfg.n_near:
            pick = rng.choice(close, cfg.n_near, replace=False)
        else:
            pick = np.argsort(d)[: cfg.n_near]
        near = cand[pick]
    out = np.concatenate([uniform, near])
    return out, np.arange(len(out)) >= len(uniform)


def sample_queries(
    scene: Scene, pool: np.ndarray, rng: np.random.Generator, config: QuerySamplerConfig | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Configurations to label: q (n_uniform + n_near, 7) [rad] from the pool, and the mask of near ones."""
    idx, near = sample_query_indices(scene, pool, rng, config)
    return pool[idx], near

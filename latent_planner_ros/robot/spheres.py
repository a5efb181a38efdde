"""The Panda as spheres: a differentiable, conservative approximation of its collision geometry.

Spheres are fitted per link to points of the collision geometry (mesh vertices, box surface samples) by
k-means; each radius covers every point assigned to its centre, so the spheres contain the geometry.
Used for differentiable self/table-collision penalties and for distance queries against point clouds.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np
import pinocchio as pin
import torch
from scipy.cluster.vq import kmeans2

from latent_planner_ros.robot.collision import CollisionChecker
from latent_planner_ros.robot.panda import LINK_FRAMES, load_panda

SPHERES_PER_LINK = {"panda_link0": 4, "panda_hand": 6, "panda_leftfinger": 2, "panda_rightfinger": 2}
DEFAULT_SPHERES = 8


@dataclass(frozen=True)
class SphereModel:
    """Spheres attached to link frames.

    Attributes:
        link: (S,) index into LINK_FRAMES of the frame each sphere is attached to.
        centre: (S, 3) centre in that frame [m].
        radius: (S,) radius [m].
        self_pairs: (P, 2) sphere index pairs whose links are checked against each other (SRDF-filtered).
    """

    link: np.ndarray
    centre: np.ndarray
    radius: np.ndarray
    self_pairs: np.ndarray

    def centres_world(self, frames: torch.Tensor) -> torch.Tensor:
        """Sphere centres in `world` (..., S, 3) from link frame poses (..., len(LINK_FRAMES), 4, 4)."""
        t = frames[..., torch.as_tensor(self.link), :3, :]  # (..., S, 3, 4)
        c = torch.as_tensor(self.centre, dtype=frames.dtype)
        c = torch.cat([c, torch.ones_like(c[:, :1])], 1)  # homogeneous (S, 4)
        return (t * c[:, None, :]).sum(-1)  # R c + p: elementwise, faster than S small matrix products

    def self_penetration(self, centres: torch.Tensor) -> torch.Tensor:
        """Sum over checked sphere pairs of their overlap depth [m], shape (...,) for centres (..., S, 3)."""
        pairs = torch.as_tensor(self.self_pairs)
        r = torch.as_tensor(self.radius, dtype=centres.dtype)
        d = (centres[..., pairs[:, 0], :] - centres[..., pairs[:, 1], :]).norm(dim=-1)
        return torch.relu(r[pairs[:, 0]] + r[pairs[:, 1]] - d).sum(-1)

    def table_penetration(self, centres: torch.Tensor) -> torch.Tensor:
        """Sum of the depth [m] below z = 0 of every sphere not on panda_link0, shape (...,)."""
        movable = torch.as_tensor(self.link != LINK_FRAMES.index("panda_link0"))
        r = torch.as_tensor(self.radius, dtype=centres.dtype)
        return (torch.relu(r - centres[..., 2]) * movable).sum(-1)


def link_geometry_objects() -> list[tuple[str, object, pin.SE3]]:
    """(link frame name, coal geometry, its placement in the link frame) of every collision geometry object."""
    panda = load_panda()
    out = []
    for g in panda.collision_model.geometryObjects:
        frame = panda.model.frames[g.parentFrame]
        out.append((frame.name, g.geometry, frame.placement.inverse() * g.placement))
    return out


def _link_points(rng: np.random.Generator) -> dict[str, np.ndarray]:
    """Points (N, 3) of each link's collision geometry in its link frame."""
    pts: dict[str, list[np.ndarray]] = {}
    for name, geo, to_frame in link_geometry_objects():
        if hasattr(geo, "vertices"):
            local = np.asarray(geo.vertices())
        elif hasattr(geo, "halfSide"):
            h = np.asarray(geo.halfSide)
            local = rng.uniform(-h, h, size=(400, 3))
            axis = rng.integers(0, 3, 400)
            local[np.arange(400), axis] = np.sign(local[np.arange(400), axis]) * h[axis]
        else:
            raise NotImplementedError(f"no point sampler for {type(geo).__name__} ({name})")
        world = (to_frame.rotation @ local.T).T + to_frame.translation
        pts.setdefault(name, []).append(world)
    return {k: np.concatenate(v) for k, v in pts.items()}


@lru_cache(maxsize=1)
def panda_spheres() -> SphereModel:
    """The fitted sphere model (deterministic; computed once per process)."""
    rng = np.random.default_rng(0)
    links, centres, radii = [], [], []
    for name, p in _link_points(rng).items():
        k = min(SPHERES_PER_LINK.get(name, DEFAULT_SPHERES), len(p))
        c, label = kmeans2(p, k, seed=rng, minit="++")
        for j in range(k):
            members = p[label == j]
            if len(members) == 0:
                continue
            links.append(LINK_FRAMES.index(name))
            centres.append(c[j])
            radii.append(np.linalg.norm(members - c[j], axis=1).max() + 1e-3)
    link = np.asarray(links)
    checker = CollisionChecker(table=False)
    link_pairs = {tuple(sorted((a.rsplit("_", 1)[0], b.rsplit("_", 1)[0]))) for a, b in checker.pair_names}
    names = [LINK_FRAMES[i] for i in link]
    pairs = [
        (i, j)
        for i in range(len(link))
        for j in range(i + 1, len(link))
        if tuple(sorted((names[i], names[j]))) in link_pairs
    ]
    return SphereModel(link=link, centre=np.asarray(centres), radius=np.asarray(radii), self_pairs=np.asarray(pairs))


def sphere_summary() -> str:
    m = panda_spheres()
    return (
        f"{len(m.radius)} spheres, radius {m.radius.min():.3f}-{m.radius.max():.3f} m, {len(m.self_pairs)} self pairs"
    )


__all__ = ["SphereModel", "panda_spheres", "sphere_summary", "pin"]

"""The Panda's collision geometry grouped per link, with simple point and sphere summaries of each link.

Everything is expressed in the link frames of LABEL_LINKS, whose world poses come from TorchFK.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import coal
import numpy as np

from latent_planner_ros.robot.panda import load_panda

LABEL_LINKS: tuple[str, ...] = (
    "panda_link1",
    "panda_link2",
    "panda_link3",
    "panda_link4",
    "panda_link5",
    "panda_link6",
    "panda_link7",
    "panda_hand",
    "panda_leftfinger",
    "panda_rightfinger",
)
"""Links that can touch scene objects (panda_link0 stands on the table, clear of every object)."""


@dataclass(frozen=True)
class LinkGeometry:
    """Per-link collision geometry of the arm (L = len(LABEL_LINKS)).

    Attributes:
        names: the link frame names, length L.
        parts: for each link, its coal geometries with their (4, 4) placement in the link frame.
        sphere_centres: (L, 3) centres [m] of spheres enclosing each link, link frame.
        sphere_radii: (L,) radii [m] of those spheres.
        surface_points: (L, S, 3) points [m] spread over each link's collision surface, link frame.
    """

    names: tuple[str, ...]
    parts: tuple[tuple[tuple[coal.CollisionGeometry, np.ndarray], ...], ...]
    sphere_centres: np.ndarray
    sphere_radii: np.ndarray
    surface_points: np.ndarray

    def axis_points(self, k: int = 3) -> np.ndarray:
        """(L, k, 3) points [m] along each link's principal axis (link frame), spread over its extent."""
        out = np.empty((len(self.names), k, 3))
        frac = (np.arange(k) + 0.5) / k
        for i, pts in enumerate(self.surface_points):
            c = pts.mean(0)
            _, _, vt = np.linalg.svd(pts - c, full_matrices=False)
            s = (pts - c) @ vt[0]
            lo, hi = np.percentile(s, [10, 90])
            out[i] = c + (lo + frac * (hi - lo))[:, None] * vt[0]
        return out


def _geometry_points(geom: coal.CollisionGeometry) -> np.ndarray:
    if isinstance(geom, coal.Box):
        h = np.asarray(geom.halfSide)
        g = np.linspace(-1.0, 1.0, 3)
        return np.array([[x, y, z] for x in g for y in g for z in g]) * h
    return np.asarray(geom.vertices(), dtype=float)


def _farthest_points(pts: np.ndarray, n: int) -> np.ndarray:
    """n points of pts (M, 3) chosen by farthest-point sampling (deterministic, starts at the first point)."""
    idx = [0]
    d = np.linalg.norm(pts - pts[0], axis=1)
    for _ in range(min(n, len(pts)) - 1):
        idx.append(int(d.argmax()))
        d = np.minimum(d, np.linalg.norm(pts - pts[idx[-1]], axis=1))
    sel = pts[idx]
    if len(sel) < n:
        sel = np.concatenate([sel, sel[np.arange(n - len(sel)) % len(sel)]])
    return sel


@lru_cache(maxsize=4)
def link_geometry(n_surface: int = 24) -> LinkGeometry:
    """Group the pinocchio collision model by link (cached); n_surface points per link."""
    panda = load_panda()
    model, gmodel = panda.model, panda.collision_model
    parts, centres, radii, surface = [], [], [], []
    for name in LABEL_LINKS:
        frame = model.frames[panda.frame_id(name)]
        frame_inv = frame.placement.inverse()
        link_parts, pts = [], []
        for g in gmodel.geometryObjects:
            if g.name.rsplit("_", 1)[0] != name:
                continue
            if g.parentJoint != frame.parentJoint:
                raise RuntimeError(f"geometry {g.name} does not hang from the joint of frame {name}")
            place = (frame_inv * g.placement).homogeneous
            link_parts.append((g.geometry, place))
            local = _geometry_points(g.geometry)
            pts.append(local @ place[:3, :3].T + place[:3, 3])
        if not link_parts:
            raise RuntimeError(f"no collision geometry for link {name}")
        pts_all = np.concatenate(pts)
        lo, hi = pts_all.min(0), pts_all.max(0)
        c = (lo + hi) / 2
        parts.append(tuple(link_parts))
        centres.append(c)
        radii.append(float(np.linalg.norm(pts_all - c, axis=1).max()))
        surface.append(_farthest_points(pts_all, n_surface))
    return LinkGeometry(
        names=LABEL_LINKS,
        parts=tuple(parts),
        sphere_centres=np.asarray(centres),
        sphere_radii=np.asarray(radii),
        surface_points=np.asarray(surface),
    )

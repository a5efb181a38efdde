"""Space no camera has seen: what lies behind an observed surface from every camera's point of view.

A point cloud marks only the surfaces the cameras saw. The hard check treats the rest as free, so a path that
passes behind a pillar or under a board seen from above can hit geometry that no point shows (the unsafe plans
of the workcell set were all such RRT escape paths, docs/benchmark.md). `ShadowMap` builds one spherical depth
map per camera from the points, and calls a point *hidden* when every camera's ray to it passes an observed
surface more than `depth_m` before reaching it. Every observed point is a real surface and blocks every camera,
so each camera's map holds all points, whichever camera saw them (a fused cloud needs only the cameras' centres).

    shadow = ShadowMap(cloud, eyes)               # cloud (N, 3) [m], eyes (K, 3) or (3,) [m]
    shadow.hidden(points)                         # (M,) bool
    HiddenArm(shadow).hidden(qs)                  # (M,) bool: a sphere centre of the arm is hidden

Directions in which a camera saw nothing (beyond the crop box, or outside its field of view) count as seen: the
map is lenient there, so it never refuses what the hard check alone would pass for lack of points.
"""

from __future__ import annotations

import numpy as np
from scipy.ndimage import minimum_filter

from latent_planner_ros.robot.panda import LINK_FRAMES
from latent_planner_ros.robot.spheres import panda_spheres
from latent_planner_ros.robot.torch_fk import TorchFK

RES_RAD = 0.012
"""angular size of a depth-map cell [rad] (the default cameras' pixels are about 0.007 rad)"""
DEPTH_M = 0.02
"""a point must lie this far behind the observed surface on its ray to be hidden [m] (depth noise, sampling)"""


class ShadowMap:
    """Per camera, the nearest observed surface in each direction; `hidden` asks them all.

    Args:
        cloud: (N, 3) [m] observed points in `world`.
        eyes: the cameras' optical centres (K, 3) or (3,) [m] (perception.cloud_fusion.camera_eyes gives them
            from per-point origins).
        res_rad: angular cell size [rad]; depth_m: see DEPTH_M.
    """

    def __init__(self, cloud: np.ndarray, eyes: np.ndarray, res_rad: float = RES_RAD, depth_m: float = DEPTH_M):
        cloud = np.asarray(cloud, dtype=float).reshape(-1, 3)
        cloud = cloud[np.isfinite(cloud).all(axis=1)]
        eyes = np.asarray(eyes, dtype=float)
        if eyes.ndim not in (1, 2) or eyes.shape[-1] != 3:
            raise ValueError(f"eyes must be (3,) or (K, 3) camera centres [m], got shape {eyes.shape}")
        eyes = eyes.reshape(-1, 3)
        eyes = eyes[np.isfinite(eyes).all(axis=1)]
        self.res = float(res_rad)
        self.depth_m = float(depth_m)
        self._n_az = int(np.ceil(2 * np.pi / self.res))
        self._n_el = int(np.ceil(np.pi / self.res)) + 1
        self.eyes: list[np.ndarray] = []
        self._maps: list[np.ndarray] = []  # per camera (n_az, n_el) nearest depth [m] (inf: nothing seen)
        if not len(cloud):
            return
        for eye in eyes:
            cell, dist = self._cells(cloud - eye)
            flat = np.full(self._n_az * self._n_el, np.inf)
            np.minimum.at(flat, cell, dist)
            # one cell's gap between the samples of a surface must not open a window through it
            depth = minimum_filter(flat.reshape(self._n_az, self._n_el), size=3, mode=("wrap", "nearest"))
            self.eyes.append(eye)
            self._maps.append(depth)

    @property
    def views(self) -> int:
        """How many cameras the map was built from."""
        return len(self._maps)

    def _cells(self, d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Flat cell index (M,) and distance (M,) [m] of offsets d (M, 3) [m] from a camera."""
        dist = np.linalg.norm(d, axis=1)
        safe = np.maximum(dist, 1e-9)
        az = np.arctan2(d[:, 1], d[:, 0])
        el = np.arcsin(np.clip(d[:, 2] / safe, -1.0, 1.0))
        i = np.floor((az + np.pi) / self.res).astype(np.int64) % self._n_az
        j = np.clip(np.floor((el + np.pi / 2) / self.res).astype(np.int64), 0, self._n_el - 1)
        return i * self._n_el + j, dist

    def hidden(self, points: np.ndarray) -> np.ndarray:
        """(M,) bool for points (M, 3) [m]: every camera saw a surface more than depth_m in front of the point
        (False for all when there is no camera)."""
        points = np.asarray(points, dtype=float).reshape(-1, 3)
        if not self._maps:
            return np.zeros(len(points), dtype=bool)
        out = np.ones(len(points), dtype=bool)
        for eye, depth in zip(self.eyes, self._maps, strict=True):
            cell, dist = self._cells(points - eye)
            out &= depth.ravel()[cell] + self.depth_m < dist
        return out


class HiddenArm:
    """Whether a configuration puts part of the arm where no camera has seen: a moving sphere centre of the
    arm's sphere model (robot/spheres.py) in `ShadowMap.hidden`. `shadow` may be replaced (one HiddenArm per
    planner, one ShadowMap per scene); None hides nothing."""

    def __init__(self, shadow: ShadowMap | None = None):
        self.shadow = shadow
        spheres = panda_spheres()
        moving = spheres.link != LINK_FRAMES.index("panda_link0")
        self._link = spheres.link[moving]
        self._centre = np.concatenate([spheres.centre[moving], np.ones((int(moving.sum()), 1))], 1)  # (S, 4)
        self._fk = TorchFK()

    def hidden(self, qs: np.ndarray) -> np.ndarray:
        """(M,) bool for configurations qs (M, 7) [rad]: some sphere centre of the arm is hidden."""
        qs = np.atleast_2d(np.asarray(qs, dtype=float))
        if self.shadow is None or not self.shadow.views or not len(qs):
            return np.zeros(len(qs), dtype=bool)
        frames = self._fk.frames_np(qs)[:, self._link, :3, :]  # (M, S, 3, 4)
        c = np.einsum("msij,sj->msi", frames, self._centre)
        hidden: np.ndarray = self.shadow.hidden(c.reshape(-1, 3)).reshape(len(qs), -1)
        return np.asarray(hidden.any(axis=1))

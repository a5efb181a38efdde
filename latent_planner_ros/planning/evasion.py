"""Evasion of observed obstacles that move towards the arm (beyond the seed).

AMP-LS sees one static scene per tick. When every step towards the goal would cross an obstacle that drives
at the arm (the conveyor bench: the target wraps to the far end of the belt, behind an oncoming obstacle), each
step is back-traced, the arm holds, and the obstacle runs into it; a step that passes the check against this
tick's cloud may still close in on it. This module notices the approach in the cloud's motion and computes a
retreat (ClosedLoopController uses it when the tick's command would not gain clearance):

- threat: the least clearance [m] of the arm's spheres (robot.spheres) to the observed cloud at the measured
  configuration, in the newest cloud and in one about `window_s` older; the arm's own motion does not enter,
  both are taken at the same configuration. The approach speed is their difference over the clouds' age gap.
- retreat: one joint step down the gradient of sum_s relu(margin - clearance_s)^2 (every sphere nearer than the
  margin pushed away from its nearest observed point), at most `max_step` per joint, kept only if it increases
  the least clearance and the straight segment to it is free of self and table collision.
"""

from __future__ import annotations

from collections import deque

import numpy as np
import torch
from scipy.spatial import cKDTree

from latent_planner_ros.planning.time_parameterisation import interpolate
from latent_planner_ros.robot.collision import CollisionChecker
from latent_planner_ros.robot.limits import Q_MAX, Q_MIN
from latent_planner_ros.robot.panda import LINK_FRAMES
from latent_planner_ros.robot.spheres import panda_spheres
from latent_planner_ros.robot.torch_fk import TorchFK

HORIZON_M = 0.3
"""[m] clearances are measured up to this far (farther counts as this far)"""


class Evader:
    """Approach measurement and retreat steps against the observed cloud.

    Args:
        margin_m: clearance [m] under which the arm's spheres are pushed away.
        window_s: [s] the approach speed compares the newest cloud with the newest one at least this much older.
        checker: self/table collision checker for retreat segments (a new one by default).
    """

    def __init__(self, margin_m: float, window_s: float = 0.3, checker: CollisionChecker | None = None):
        self.margin = float(margin_m)
        self.window = float(window_s)
        self._spheres = panda_spheres()
        moving = self._spheres.link != LINK_FRAMES.index("panda_link0")  # the base stands on the table
        self._moving = torch.as_tensor(np.flatnonzero(moving))
        self._radius = self._spheres.radius[moving]
        self._fk = TorchFK(dtype=torch.float64)
        self._checker = checker or CollisionChecker()
        self._clouds: deque[tuple[float, cKDTree | None]] = deque()

    @property
    def newest_time(self) -> float:
        """Time [s] of the newest cloud (-inf before any)."""
        return self._clouds[-1][0] if self._clouds else -np.inf

    def add_cloud(self, cloud: np.ndarray, now: float) -> None:
        """The observed cloud (N, 3) [m] at time now [s] (finite points, robot removed)."""
        if self._clouds and now < self._clouds[-1][0]:  # the clock went back: start afresh
            self._clouds.clear()
        cloud = np.asarray(cloud, dtype=float).reshape(-1, 3)
        self._clouds.append((now, cKDTree(cloud) if len(cloud) else None))
        while len(self._clouds) > 2 and now - self._clouds[1][0] >= self.window:
            self._clouds.popleft()

    def _centres(self, q: torch.Tensor) -> torch.Tensor:
        """Sphere centres (S, 3) [m] of configuration q (7,)."""
        return self._spheres.centres_world(self._fk(q))[self._moving]

    def _nearest(self, centres: np.ndarray, tree: cKDTree | None) -> tuple[np.ndarray, np.ndarray]:
        """Clearance (S,) [m] (capped at HORIZON_M) and nearest observed point (S, 3) of every sphere."""
        if tree is None:
            return np.full(len(centres), HORIZON_M), np.zeros_like(centres)
        d, i = tree.query(centres, distance_upper_bound=HORIZON_M + float(self._radius.max()))
        found = np.isfinite(d)
        points = np.zeros_like(centres)
        points[found] = tree.data[np.asarray(i)[found]]
        return np.minimum(np.where(found, d - self._radius, HORIZON_M), HORIZON_M), points

    def least_clearance(self, q: np.ndarray, newest: bool = True) -> float:
        """Least sphere clearance [m] of q (7,) [rad] in the newest (or the oldest kept) cloud."""
        if not self._clouds:
            return HORIZON_M
        with torch.no_grad():
            centres = self._centres(torch.as_tensor(q, dtype=torch.float64)).numpy()
        tree = self._clouds[-1 if newest else 0][1]
        return float(self._nearest(centres, tree)[0].min())

    def threat(self, q: np.ndarray) -> tuple[float, float]:
        """(least clearance [m], approach speed [m/s]) of the observed cloud to the arm held at q (7,) [rad];
        the speed is 0 until two clouds at least 50 ms apart were seen."""
        clearance = self.least_clearance(q)
        if len(self._clouds) < 2 or self._clouds[-1][0] - self._clouds[0][0] < 0.05:
            return clearance, 0.0
        before = self.least_clearance(q, newest=False)
        return clearance, (before - clearance) / (self._clouds[-1][0] - self._clouds[0][0])

    def retreat(self, q: np.ndarray, max_step: np.ndarray) -> np.ndarray | None:
        """A configuration (7,) [rad] that moves q (7,) away from the observed points nearer than the margin, each
        joint by at most max_step (7,) [rad]; None when no such step increases the least clearance safely."""
        if not self._clouds or self._clouds[-1][1] is None:
            return None
        tree = self._clouds[-1][1]
        qt = torch.as_tensor(q, dtype=torch.float64).clone().requires_grad_(True)
        centres = self._centres(qt)
        clearance, points = self._nearest(centres.detach().numpy(), tree)
        near = clearance < self.margin
        if not near.any():
            return None
        gap = (centres[near] - torch.as_tensor(points[near])).norm(dim=-1) - torch.as_tensor(self._radius[near])
        torch.relu(self.margin - gap).pow(2).sum().backward()
        assert qt.grad is not None  # set by backward()
        direction = -qt.grad.numpy()
        scale = float(np.max(np.abs(direction) / np.maximum(max_step, 1e-9)))
        if not np.isfinite(scale) or scale <= 0.0:
            return None
        least = float(clearance.min())
        for fraction in (1.0, 0.5, 0.25):
            q_new = np.clip(q + fraction * direction / scale, Q_MIN, Q_MAX)
            if self.least_clearance(q_new) <= least:
                continue
            segment = interpolate(q, q_new, 4)
            if self._checker.feasible(segment).all():
                return q_new
        return None

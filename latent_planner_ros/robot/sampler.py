"""Feasible-state sampler: uniform in the joint limits, rejecting self and table collisions."""

from __future__ import annotations

import numpy as np

from latent_planner_ros.robot.collision import CollisionChecker
from latent_planner_ros.robot.limits import Q_MAX, Q_MIN


class FeasibleSampler:
    """Draws kinematically feasible configurations.

    Args:
        rng: the numpy Generator to draw from (the caller owns seeding; no global RNG is touched).
        table: also reject configurations that touch the table (z < 0).
    """

    def __init__(self, rng: np.random.Generator, table: bool = True):
        self.rng = rng
        self.checker = CollisionChecker(table=table)
        self._accept = 0.8  # running estimate of the acceptance rate, sizes the next draw

    def sample(self, n: int) -> np.ndarray:
        """n feasible configurations, shape (n, 7) [rad], uniform over the feasible set."""
        out: list[np.ndarray] = []
        have = 0
        while have < n:
            m = int((n - have) / max(self._accept, 0.05) * 1.1) + 8
            q = self.rng.uniform(Q_MIN, Q_MAX, size=(m, 7))
            ok = self.checker.feasible(q)
            self._accept = 0.9 * self._accept + 0.1 * max(ok.mean(), 0.01)
            out.append(q[ok])
            have += int(ok.sum())
        return np.concatenate(out)[:n]

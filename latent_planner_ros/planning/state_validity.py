"""State validity shared by the OMPL checkers: joint limits, then self and table collision, then obstacles."""

from __future__ import annotations

import numpy as np

from latent_planner_ros.robot.collision import CollisionChecker
from latent_planner_ros.robot.limits import Q_MAX, Q_MIN


class StateValidity:
    """Mixin: a checker with `self_checker` (robot.collision.CollisionChecker), a `checks` counter and
    `colliding_links(q, first_only)` gets `invalid_reason`, `is_valid` and `first_invalid`."""

    obstacle_hit = "touches an obstacle"
    """how a link's obstacle contact is reported (after the link's name)"""
    checks: int
    """configurations checked so far (set by the checker)"""
    self_checker: CollisionChecker
    """self and table collision (set by the checker)"""

    def colliding_links(self, q: np.ndarray, first_only: bool = False) -> list[str]:
        """Names of the links of q (7,) [rad] touching an obstacle (the first only if first_only)."""
        raise NotImplementedError

    def invalid_reason(self, q: np.ndarray) -> str | None:
        """None if q (7,) [rad] is valid, else the first reason found ("self-collision", ...)."""
        self.checks += 1
        q = np.asarray(q, dtype=float)
        if not np.all(np.isfinite(q)) or np.any(q < Q_MIN) or np.any(q > Q_MAX):
            return "outside the joint limits"
        self_hit, table_hit = self.self_checker.collisions(q) if self.self_checker.in_collision(q) else (False, False)
        if self_hit:
            return "self-collision"
        if table_hit:
            return "table collision"
        links = self.colliding_links(q, first_only=True)
        if links:
            return f"{links[0]} {self.obstacle_hit}"
        return None

    def is_valid(self, q: np.ndarray) -> bool:
        return self.invalid_reason(q) is None

    def first_invalid(self, q_path: np.ndarray) -> int:
        """Index of the first invalid configuration of q_path (T, 7) [rad], or -1 if all are valid."""
        for i, q in enumerate(np.atleast_2d(q_path)):
            if not self.is_valid(q):
                return i
        return -1

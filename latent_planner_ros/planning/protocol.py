"""The small protocol every planner implements, so nodes and benchmarks treat them alike."""

from __future__ import annotations

from typing import Protocol

import numpy as np

from latent_planner_ros.planning.goal import Goal
from latent_planner_ros.planning.result import PlanResult


class Planner(Protocol):
    """Plans from a start configuration to a goal pose in a scene seen as a point cloud."""

    name: str

    def plan(self, start_q: np.ndarray, goal: Goal, cloud: np.ndarray, origin: np.ndarray | None = None) -> PlanResult:
        """start_q (7,) [rad]; cloud (N, 3) [m] in `world` (robot points removed); origin (3,) [m] in `world`:
        the camera's optical centre the cloud was seen from, if known (only the learned backend reads it)."""
        ...

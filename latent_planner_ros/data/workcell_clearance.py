"""Exact distance from the whole arm (every link, the hand and the fingers) to a scene's obstacles (coal).

Link/obstacle pairs whose bounding spheres are farther apart than the best distance found so far are skipped,
so the answer is the exact minimum over all pairs.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import coal
import numpy as np

from latent_planner_ros.data.labels import link_poses
from latent_planner_ros.data.link_geometry import LinkGeometry, link_geometry
from latent_planner_ros.data.obstacle_geometry import coal_geometry
from latent_planner_ros.data.obstacles import Obstacle, bounding_sphere


@dataclass(frozen=True)
class Clearance:
    """The smallest arm-obstacle distance of one configuration.

    Attributes:
        distance: [m]; zero or negative when the arm touches an obstacle, inf without obstacles.
        on_arm: (3,) nearest point [m] on the arm, `world`.
        on_obstacle: (3,) nearest point [m] on the obstacle, `world`.
        link: index into LABEL_LINKS of the nearest link.
    """

    distance: float
    on_arm: np.ndarray
    on_obstacle: np.ndarray
    link: int


class ArmDistance:
    """Distances between the arm and fixed obstacles.

    Args:
        obstacles: the obstacles (`world`).
        links: the arm's per-link geometry (default: the shared cached one).
    """

    def __init__(self, obstacles: Sequence[Obstacle], links: LinkGeometry | None = None):
        self.links = links or link_geometry()
        self.objects = [coal_geometry(o) for o in obstacles]
        spheres = [bounding_sphere(o) for o in obstacles]
        self.centres = np.array([c for c, _ in spheres]).reshape(-1, 3)
        self.radii = np.array([r for _, r in spheres])
        self._request = coal.DistanceRequest()
        self._result = coal.DistanceResult()

    def __call__(self, q: np.ndarray) -> Clearance:
        """The clearance of one configuration q (7,) [rad]."""
        poses = link_poses(np.asarray(q, dtype=float)[None])[0]
        best = Clearance(math.inf, np.zeros(3), np.zeros(3), -1)
        if not self.objects:
            return best
        centres = np.einsum("lij,lj->li", poses[:, :3, :3], self.links.sphere_centres) + poses[:, :3, 3]
        gap = np.linalg.norm(centres[:, None] - self.centres[None], axis=-1)
        gap -= self.links.sphere_radii[:, None] + self.radii[None]  # (L, O) lower bounds of the distances
        for link, o in sorted(np.ndindex(gap.shape), key=lambda lo: gap[lo]):
            if gap[link, o] >= best.distance:
                break
            geom_o, tf_o = self.objects[o]
            for geom_l, place in self.links.parts[link]:
                t = poses[link] @ place
                self._result.clear()
                d = coal.distance(
                    geom_l, coal.Transform3s(t[:3, :3], t[:3, 3]), geom_o, tf_o, self._request, self._result
                )
                if d < best.distance:
                    best = Clearance(
                        float(d),
                        np.array(self._result.getNearestPoint1(), dtype=float),
                        np.array(self._result.getNearestPoint2(), dtype=float),
                        int(link),
                    )
        return best

"""Exact collision labels between the Panda's links and a scene's obstacles (coal), per link.

Two exact tests skip link/obstacle pairs that cannot touch: the link's enclosing sphere against the obstacle's
bounding sphere, then against the obstacle's own shape (obstacles.distance_below: a tall thin cylinder's bounding
sphere is mostly empty); the remaining pairs go to coal.collide with the link's collision meshes (and finger
boxes) at their world placement.
"""

from __future__ import annotations

import coal
import numpy as np
import torch

from latent_planner_ros.data.link_geometry import LinkGeometry, link_geometry
from latent_planner_ros.data.obstacle_geometry import coal_geometry
from latent_planner_ros.data.obstacles import bounding_sphere, distance_below
from latent_planner_ros.data.scene import Scene
from latent_planner_ros.robot.torch_fk import TorchFK

_FK: TorchFK | None = None


def link_poses(q: np.ndarray) -> np.ndarray:
    """World poses (N, L, 4, 4) of the LABEL_LINKS frames for configurations q (N, 7) [rad] (float64)."""
    global _FK
    if _FK is None:
        _FK = TorchFK(frames=link_geometry().names, dtype=torch.float64)
    with torch.no_grad():
        return _FK(torch.as_tensor(np.asarray(q, dtype=float).reshape(-1, 7))).numpy()


class CollisionLabeler:
    """Labels configurations against the obstacles of one scene (not the table, not self-collision).

    Args:
        scene: the obstacles.
        links: the arm's per-link geometry (default: the shared cached one).
    """

    def __init__(self, scene: Scene, links: LinkGeometry | None = None):
        self.scene = scene
        self.links = links or link_geometry()
        self.objects = [coal_geometry(o) for o in scene.obstacles]
        spheres = [bounding_sphere(o) for o in scene.obstacles]
        self.obstacle_centres = np.array([c for c, _ in spheres]).reshape(-1, 3)
        self.obstacle_radii = np.array([r for _, r in spheres])
        self._request = coal.CollisionRequest()
        self._result = coal.CollisionResult()
        self.pairs_checked = 0
        """coal.collide calls made so far (for throughput reports)"""

    def label_poses(self, poses: np.ndarray) -> np.ndarray:
        """Per-link collision (N, L) bool for link poses (N, L, 4, 4) from :func:`link_poses`."""
        n, n_links = poses.shape[:2]
        out = np.zeros((n, n_links), dtype=bool)
        if len(self.objects) == 0:
            return out
        centres = np.einsum("nlij,lj->nli", poses[..., :3, :3], self.links.sphere_centres) + poses[..., :3, 3]
        gap = np.linalg.norm(centres[:, :, None, :] - self.obstacle_centres[None, None], axis=-1)
        maybe = gap < self.links.sphere_radii[None, :, None] + self.obstacle_radii[None, None, :]  # (N, L, O)
        for o in np.flatnonzero(maybe.any(axis=(0, 1))):  # the obstacle's own shape against the link spheres
            i, link = np.nonzero(maybe[:, :, o])
            maybe[i, link, o] = (
                distance_below(self.scene.obstacles[o], centres[i, link]) < self.links.sphere_radii[link]
            )
        for i, link, o in zip(*np.nonzero(maybe), strict=True):
            if out[i, link]:
                continue
            geom_o, tf_o = self.objects[o]
            for geom_l, place in self.links.parts[link]:
                t = poses[i, link] @ place
                self._result.clear()
                self.pairs_checked += 1
                if coal.collide(
                    geom_l, coal.Transform3s(t[:3, :3], t[:3, 3]), geom_o, tf_o, self._request, self._result
                ):
                    out[i, link] = True
                    break
        return out

    def contact_points(self, q: np.ndarray) -> list[np.ndarray]:
        """Contact points (K, 3) [m] in `world` of each configuration q (N, 7) [rad] with the obstacles (coal's
        contacts of every colliding link part and obstacle; (0, 3) for a free configuration)."""
        request = coal.CollisionRequest()
        request.enable_contact = True
        request.num_max_contacts = 4
        result = coal.CollisionResult()
        poses = link_poses(np.atleast_2d(q))
        out = []
        for pose in poses:
            points = []
            for link, parts in enumerate(self.links.parts):
                for geom_l, place in parts:
                    t = pose[link] @ place
                    tf_l = coal.Transform3s(t[:3, :3], t[:3, 3])
                    for geom_o, tf_o in self.objects:
                        result.clear()
                        if coal.collide(geom_l, tf_l, geom_o, tf_o, request, result):
                            points += [np.array(c.pos, dtype=float) for c in result.getContacts()]
            out.append(np.array(points, dtype=float).reshape(-1, 3))
        return out

    def label(self, q: np.ndarray) -> np.ndarray:
        """Per-link collision (N, L) bool for configurations q (N, 7) [rad]; any(axis=1) is the global label."""
        return self.label_poses(link_poses(q))

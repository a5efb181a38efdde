"""Configuration validity against the EXACT obstacle geometry of a known scene (e.g. LSPP's cylinders).

The counterpart of `octree_checker.OctreeChecker` when the obstacles are given as primitives instead of a
point cloud: a configuration is valid when it is within the joint limits, free of self and table collision
(`robot.collision.CollisionChecker`) and no link's collision geometry (`data.link_geometry`, placed by
pinocchio FK) touches an obstacle's coal geometry (`data.obstacle_geometry`). A bounding-sphere test skips
link/obstacle pairs that cannot touch, as `data.labels.CollisionLabeler` does.
"""

from __future__ import annotations

import coal
import numpy as np
import pinocchio as pin

from latent_planner_ros.data.link_geometry import LinkGeometry, link_geometry
from latent_planner_ros.data.obstacle_geometry import coal_geometry
from latent_planner_ros.data.obstacles import bounding_sphere
from latent_planner_ros.data.scene import Scene
from latent_planner_ros.planning.state_validity import StateValidity
from latent_planner_ros.robot.collision import CollisionChecker
from latent_planner_ros.robot.panda import PandaModel, load_panda

_POINT_RADIUS = 1e-3
"""Radius [m] of the probe sphere of `contains`."""


class SceneChecker(StateValidity):
    """Says whether (and why not) a configuration is valid in a known scene. Not thread-safe.

    Same interface as `OctreeChecker` (`is_valid`, `invalid_reason`, `first_invalid`, `checks`), with
    `set_scene` in place of `set_occupancy`.

    Args:
        scene: the obstacles (default: none).
        table: check the table half-space (z < 0).
        padding: clearance [m] the links must keep from the obstacles (coal security margin).
        panda: the pinocchio model (default: the shared one).
    """

    def __init__(
        self,
        scene: Scene | None = None,
        table: bool = True,
        padding: float = 0.0,
        panda: PandaModel | None = None,
    ):
        self.panda = panda or load_panda()
        self.links: LinkGeometry = link_geometry()
        self.self_checker = CollisionChecker(self.panda, table=table, convex=True)
        self._frame_ids = [self.panda.frame_id(name) for name in self.links.names]
        self._padding = float(padding)
        self._data = self.panda.model.createData()
        self._request = coal.CollisionRequest()
        self._request.security_margin = float(padding)
        self._result = coal.CollisionResult()
        self.checks = 0
        """configurations checked so far"""
        self.set_scene(scene or Scene((), family="empty"))

    def set_scene(self, scene: Scene) -> None:
        """Check against the obstacles of `scene` from now on."""
        self.scene = scene
        self._objects = [coal_geometry(o) for o in scene.obstacles]
        spheres = [bounding_sphere(o) for o in scene.obstacles]
        self._centres = np.array([c for c, _ in spheres], dtype=float).reshape(-1, 3)
        self._radii = np.array([r for _, r in spheres], dtype=float)

    def contains(self, point: np.ndarray, radius: float = _POINT_RADIUS) -> bool:
        """True if a sphere of `radius` [m] at point (3,) [m] in `world` touches an obstacle."""
        tf = coal.Transform3s(np.eye(3), np.asarray(point, dtype=float))
        probe = coal.Sphere(radius)
        for geometry, place in self._objects:
            self._result.clear()
            if coal.collide(probe, tf, geometry, place, coal.CollisionRequest(), self._result):
                return True
        return False

    def colliding_links(self, q: np.ndarray, first_only: bool = False) -> list[str]:
        """Names of the links of q (7,) [rad] touching (or within `padding` of) an obstacle."""
        if not self._objects:
            return []
        pin.framesForwardKinematics(self.panda.model, self._data, np.asarray(q, dtype=float))
        poses = [self._data.oMf[fid].homogeneous for fid in self._frame_ids]
        centres = np.array([p[:3, :3] @ c + p[:3, 3] for p, c in zip(poses, self.links.sphere_centres, strict=True)])
        gap = np.linalg.norm(centres[:, None, :] - self._centres[None], axis=-1)  # (L, O)
        maybe = gap <= self.links.sphere_radii[:, None] + self._radii[None] + self._padding
        hits: list[str] = []
        for k in np.flatnonzero(maybe.any(axis=1)):
            if self._link_hits(poses[k], int(k), np.flatnonzero(maybe[k])):
                hits.append(self.links.names[k])
                if first_only:
                    break
        return hits

    def _link_hits(self, pose: np.ndarray, k: int, obstacles: np.ndarray) -> bool:
        """Whether link k at pose (4, 4) touches any of the obstacles (indices)."""
        for geometry, place in self.links.parts[k]:
            t = pose @ place
            placed = coal.Transform3s(t[:3, :3], t[:3, 3])
            for o in obstacles:
                geom_o, tf_o = self._objects[o]
                self._result.clear()
                if coal.collide(geometry, placed, geom_o, tf_o, self._request, self._result):
                    return True
        return False

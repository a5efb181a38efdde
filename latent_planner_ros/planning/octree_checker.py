"""Configuration validity for sampling-based planning: joint limits, self and table collision (exact meshes),
and the arm's collision geometry against an occupancy map of the observed point cloud.

The occupancy map is a coal.OcTree built from the cloud at a fixed resolution, as MoveIt does with octomap:
every voxel holding a point is occupied, the rest (free or unseen) counts as free. Points below `min_z` are
dropped before building it, because the table top (z = 0) is already checked exactly as a half-space and
its voxels would otherwise reach `resolution` above it. The arm's geometry is the per-link coal geometry of
`data.link_geometry` placed by pinocchio FK.
"""

from __future__ import annotations

from dataclasses import dataclass

import coal
import numpy as np
import pinocchio as pin
from scipy.spatial import cKDTree

from latent_planner_ros.data.link_geometry import LinkGeometry, link_geometry
from latent_planner_ros.planning.state_validity import StateValidity
from latent_planner_ros.robot.collision import CollisionChecker
from latent_planner_ros.robot.panda import PandaModel, load_panda

_IDENTITY = coal.Transform3s()


def _split(t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Rotation (3, 3) and translation (3,) of a homogeneous transform (4, 4)."""
    return t[:3, :3], t[:3, 3]


@dataclass(frozen=True)
class OccupancyMap:
    """An occupancy map of a cloud.

    Attributes:
        tree: the coal.OcTree, or None when no point survived the filtering (nothing is occupied).
        points: (M, 3) [m] the points that went into the tree, in a KD-tree (a cheap prefilter: no occupied
            voxel lies farther than resolution * sqrt(3) from its points).
        resolution: voxel edge [m].
        points_in: points received (N of the (N, 3) input).
        points_used: finite points at or above min_z that went into the tree.
    """

    tree: coal.OcTree | None
    points: cKDTree | None
    resolution: float
    points_in: int
    points_used: int

    @classmethod
    def from_cloud(cls, cloud: np.ndarray | None, resolution: float = 0.02, min_z: float = 0.01) -> OccupancyMap:
        """Occupancy of cloud (N, 3) [m] in `world` at `resolution` [m]; points with z < min_z [m] dropped."""
        if not (np.isfinite(resolution) and resolution > 0):
            raise ValueError(f"resolution must be a positive number of metres, got {resolution!r}")
        pts = np.zeros((0, 3)) if cloud is None else np.asarray(cloud, dtype=float).reshape(-1, 3)
        n_in = len(pts)
        pts = pts[np.all(np.isfinite(pts), axis=1)]
        pts = pts[pts[:, 2] >= min_z]
        if not len(pts):
            return cls(None, None, float(resolution), n_in, 0)
        tree = coal.makeOctree(np.ascontiguousarray(pts), float(resolution))
        kd = cKDTree(pts, balanced_tree=False, compact_nodes=False)  # half the build time, the same answers
        return cls(tree, kd, float(resolution), n_in, len(pts))

    @property
    def occupied_voxels(self) -> int:
        """Number of occupied leaf voxels."""
        return 0 if self.tree is None else len(self.tree.toBoxes())

    def contains(self, point: np.ndarray, radius: float = 1e-3) -> bool:
        """True if a sphere of `radius` [m] at point (3,) [m] touches an occupied voxel."""
        if self.tree is None:
            return False
        tf = coal.Transform3s(np.eye(3), np.asarray(point, dtype=float))
        return bool(
            coal.collide(coal.Sphere(radius), tf, self.tree, _IDENTITY, coal.CollisionRequest(), coal.CollisionResult())
        )


class OctreeChecker(StateValidity):
    """Says whether (and why not) a configuration is valid. Not thread-safe (holds pinocchio Data).

    Args:
        occupancy: the occupancy map (default: empty).
        table: check the table half-space (z < 0).
        padding: clearance [m] the links must keep from occupied voxels (coal security margin).
        panda: the pinocchio model (default: the shared one).
    """

    obstacle_hit = "in an occupied voxel"

    def __init__(
        self,
        occupancy: OccupancyMap | None = None,
        table: bool = True,
        padding: float = 0.0,
        panda: PandaModel | None = None,
    ):
        self.panda = panda or load_panda()
        self.occupancy = occupancy or OccupancyMap.from_cloud(None)
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

    def set_occupancy(self, occupancy: OccupancyMap) -> None:
        self.occupancy = occupancy

    def colliding_links(self, q: np.ndarray, first_only: bool = False) -> list[str]:
        """Names of the links of q (7,) [rad] touching an occupied voxel."""
        tree, points = self.occupancy.tree, self.occupancy.points
        if tree is None or points is None:  # both None together: nothing is occupied
            return []
        pin.framesForwardKinematics(self.panda.model, self._data, np.asarray(q, dtype=float))
        poses = [self._data.oMf[fid].homogeneous for fid in self._frame_ids]
        centres = np.array([p[:3, :3] @ c + p[:3, 3] for p, c in zip(poses, self.links.sphere_centres, strict=True)])
        gap, _ = points.query(centres)
        reach = self.links.sphere_radii + self.occupancy.resolution * np.sqrt(3.0) + self._padding
        hits = []
        for k in np.flatnonzero(gap <= reach):
            name, parts, pose = self.links.names[k], self.links.parts[k], poses[k]
            for geometry, place in parts:
                t = pose @ place
                self._result.clear()
                if coal.collide(
                    geometry, coal.Transform3s(t[:3, :3], t[:3, 3]), tree, _IDENTITY, self._request, self._result
                ):
                    hits.append(name)
                    break
            if hits and first_only:
                break
        return hits

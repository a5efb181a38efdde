"""Self-collision and table collision of the Panda through pinocchio's coal bindings.

Self-collision pairs are every pair of collision geometries minus those the SRDF disables. The table is
the half-space z < 0 (a large box whose top face is at z = 0); panda_link0 stands on it and is exempt.
Planners may check the convex hulls of the link meshes instead (`convex`): about twice as fast, and never
less conservative than the meshes they enclose. Batches (`feasible`) go through pinocchio's broad phase (an
AABB tree of the geometries, narrow phase only for overlapping boxes) in one call: the same answers as checking
every pair, about four times faster per configuration; single configurations (`in_collision`) go through
the broad phase too, about twice as fast as every pair.
"""

from __future__ import annotations

import ctypes
from dataclasses import dataclass, field

import coal
import numpy as np
import pinocchio as pin

from latent_planner_ros.robot.description import panda_description
from latent_planner_ros.robot.panda import PandaModel, load_panda

TABLE_NAME = "table"
TABLE_HALF_EXTENTS = (2.0, 2.0, 0.5)
"""Half extents [m] of the box that stands for the table (top face at z = 0)."""


def _openmp() -> ctypes.CDLL | None:
    """The process's OpenMP runtime (torch and pinocchio share one libgomp.so.1), or None if there is none."""
    try:
        return ctypes.CDLL("libgomp.so.1")
    except OSError:
        return None


_OPENMP = _openmp()


def _link_of(geometry_name: str) -> str:
    return geometry_name.rsplit("_", 1)[0]


@dataclass
class CollisionChecker:
    """Checks configurations for self-collision and table collision.

    Not thread-safe: each thread or process makes its own (it holds pinocchio Data objects).

    Attributes:
        panda: the pinocchio model.
        table: whether the table half-space counts as an obstacle.
        convex: check the convex hull of each link mesh instead of the mesh (a hull contains its mesh, so a
            configuration free for the hulls is free for the meshes).
    """

    panda: PandaModel = field(default_factory=load_panda)
    table: bool = True
    convex: bool = False

    def __post_init__(self) -> None:
        model = self.panda.model
        geom = self.panda.collision_model.copy()
        if self.convex:
            for obj in geom.geometryObjects:
                if isinstance(obj.geometry, coal.BVHModelBase):
                    obj.geometry.buildConvexRepresentation(False)
                    obj.geometry = obj.geometry.convex
        if self.table:
            hx, hy, hz = TABLE_HALF_EXTENTS
            place = pin.SE3(np.eye(3), np.array([0.0, 0.0, -hz]))
            table = pin.GeometryObject(TABLE_NAME, 0, 0, place, coal.Box(2 * hx, 2 * hy, 2 * hz))
            geom.addGeometryObject(table)
        geom.addAllCollisionPairs()
        pin.removeCollisionPairs(model, geom, str(panda_description().srdf))
        # The table only collides with links that can reach it; link0 stands on it.
        table_id = geom.getGeometryId(TABLE_NAME) if self.table else -1
        self.self_pairs: list[int] = []
        self.table_pairs: list[int] = []
        for k, cp in enumerate(geom.collisionPairs):
            names = {geom.geometryObjects[cp.first].name, geom.geometryObjects[cp.second].name}
            if table_id in (cp.first, cp.second):
                (other,) = names - {TABLE_NAME}
                (self.table_pairs if _link_of(other) != "panda_link0" else []).append(k)
            else:
                self.self_pairs.append(k)
        active = set(self.self_pairs) | set(self.table_pairs)
        keep = [geom.collisionPairs[k] for k in sorted(active)]
        geom.removeAllCollisionPairs()
        for cp in keep:
            geom.addCollisionPair(cp)
        self.geom = geom
        pair_names = [
            (geom.geometryObjects[cp.first].name, geom.geometryObjects[cp.second].name) for cp in geom.collisionPairs
        ]
        self._is_table_pair = np.array([TABLE_NAME in pair for pair in pair_names])
        self.pair_names = pair_names
        self._data = model.createData()
        self._gdata = pin.GeometryData(geom)
        self._pool = None  # the broad-phase pool of `feasible`, built on first use
        self._manager = None  # the broad phase of `in_collision`, built on first use
        self._manager_data = None  # the geometry data that manager updates (kept alive with it)

    def collisions(self, q: np.ndarray) -> tuple[bool, bool]:
        """(self-collision, table collision) for one configuration q (shape (7,), rad)."""
        pin.computeCollisions(self.panda.model, self._data, self.geom, self._gdata, np.asarray(q, dtype=float), False)
        hits = np.array([r.isCollision() for r in self._gdata.collisionResults])
        return bool(np.any(hits & ~self._is_table_pair)), bool(np.any(hits & self._is_table_pair))

    def in_collision(self, q: np.ndarray) -> bool:
        """True if q (shape (7,), rad) is in self or table collision (stops at the first contact); through the
        broad phase, like `feasible`."""
        if self._manager is None:
            self._manager_data = pin.GeometryData(self.geom)
            self._manager = pin.BroadPhaseManager_DynamicAABBTreeArrayCollisionManager(
                self.panda.model, self.geom, self._manager_data
            )
        return bool(
            pin.computeCollisions(self.panda.model, self._data, self._manager, np.asarray(q, dtype=float), True)
        )

    def feasible(self, q: np.ndarray) -> np.ndarray:
        """Boolean mask (N,) of collision-free configurations among q (shape (N, 7), rad).

        One call into pinocchio's broad phase for the whole batch (single-threaded); the active pairs are the
        ones `in_collision` checks, so the answers are the same. That call sets the OpenMP thread count of the
        process to its own (1); the count from before is restored, so torch keeps its threads.
        """
        q = np.atleast_2d(np.asarray(q, dtype=float))
        if q.shape[1] != self.panda.model.nq:
            raise ValueError(f"expected configurations of {self.panda.model.nq} joints, got shape {q.shape}")
        if len(q) == 0:
            return np.zeros(0, dtype=bool)
        if self._pool is None:
            self._pool = pin.TreeBroadPhaseManagerPool_DynamicAABBTreeCollisionManager(self.panda.model, self.geom, 1)
        threads = _OPENMP.omp_get_max_threads() if _OPENMP is not None else None
        try:
            hits = pin.computeCollisionsInParallel(1, self._pool, np.asfortranarray(q.T), True)
        finally:
            if threads is not None and _OPENMP is not None:
                _OPENMP.omp_set_num_threads(threads)
        return ~np.asarray(hits, dtype=bool)

"""The Panda's collision meshes (example-robot-data STLs, finger boxes) and their poses for a joint state. No ROS.

meshes = robot_meshes()                 # once: vertices/faces per geometry
for name, (wxyz, xyz) in meshes.poses(q).items(): ...
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cache

import numpy as np
import pinocchio as pin

from latent_planner_ros.robot.panda import load_panda


@dataclass(frozen=True)
class Mesh:
    """One collision geometry: `vertices` (V, 3) [m] and `faces` (F, 3) in its own frame; `link` its parent link."""

    name: str
    link: str
    vertices: np.ndarray
    faces: np.ndarray


def _box(half: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    import trimesh

    box = trimesh.creation.box(extents=2.0 * np.asarray(half, dtype=float))
    return np.asarray(box.vertices), np.asarray(box.faces)


class RobotMeshes:
    """The meshes of the arm model (robot/panda.py) and their placements in `world` for configurations q (7,)."""

    def __init__(self):
        import trimesh

        panda = load_panda()
        self.model, self.geometry = panda.model, panda.collision_model
        self._data = self.model.createData()
        self._gdata = pin.GeometryData(self.geometry)
        self.meshes: list[Mesh] = []
        for g in self.geometry.geometryObjects:
            link = self.model.frames[g.parentFrame].name
            if g.meshPath and g.meshPath.lower().endswith(".stl"):
                tm = trimesh.load(g.meshPath, force="mesh")
                vertices, faces = np.asarray(tm.vertices) * np.asarray(g.meshScale), np.asarray(tm.faces)
            elif hasattr(g.geometry, "halfSide"):
                vertices, faces = _box(g.geometry.halfSide)
            else:
                continue
            self.meshes.append(Mesh(g.name, link, vertices.astype(np.float32), faces.astype(np.uint32)))
        self._index = [self.geometry.getGeometryId(m.name) for m in self.meshes]

    def poses(self, q: np.ndarray) -> dict[str, tuple[np.ndarray, np.ndarray]]:
        """{mesh name: (wxyz (4,), position (3,) [m])} in `world` for the arm configuration q (7,) [rad]."""
        pin.updateGeometryPlacements(self.model, self._data, self.geometry, self._gdata, np.asarray(q, dtype=float))
        out = {}
        for mesh, gid in zip(self.meshes, self._index, strict=True):
            placement = self._gdata.oMg[gid]
            xyzw = pin.Quaternion(placement.rotation).coeffs()  # (x, y, z, w)
            out[mesh.name] = (np.array([xyzw[3], xyzw[0], xyzw[1], xyzw[2]]), placement.translation.copy())
        return out

    def tcp(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(wxyz, position [m]) of the TCP frame for q (7,)."""
        pose = load_panda().fk(q)
        xyzw = pin.Quaternion(pose.rotation).coeffs()
        return np.array([xyzw[3], xyzw[0], xyzw[1], xyzw[2]]), pose.translation.copy()


@cache
def robot_meshes() -> RobotMeshes:
    """The meshes, loaded once per process."""
    return RobotMeshes()

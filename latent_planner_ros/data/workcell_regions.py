"""Where goals go in a piece of furniture: interior regions (oriented boxes) and approachable surfaces.

A `Furniture` is the obstacles of one piece (a bookshelf, a bin, ...) with

- `regions`: free space inside it (a shelf slot, a bin's inside, the space under a shelf, a window of a cage),
  each an oriented box with the direction a gripper enters it;
- `surfaces`: rectangular patches of its outer surface with their outward normal (a board's front edge, a bin's
  rim, the underside of a shelf), where a pre-grasp pose stands a few centimetres off.

Everything is in `world` (metres) once placed; builders make them in a local frame and move them with
`Furniture.moved`.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from latent_planner_ros.data.obstacles import Obstacle, transformed


def _t3(v) -> tuple[float, float, float]:
    a = np.asarray(v, dtype=float).reshape(3)
    return (float(a[0]), float(a[1]), float(a[2]))


@dataclass(frozen=True)
class Region:
    """An oriented box of free space.

    Attributes:
        centre: (3,) [m].
        axes: (3, 3) rotation whose columns are the box's local x, y, z axes in `world`.
        half_extents: (3,) half side lengths [m] along those axes.
        approach: (3,) unit direction a gripper moves in when it enters (the TCP's z axis), `world`.
        kind: "slot", "bin", "under", "window" or "gap".
    """

    centre: tuple[float, float, float]
    axes: np.ndarray
    half_extents: tuple[float, float, float]
    approach: tuple[float, float, float]
    kind: str

    def local(self, p: np.ndarray) -> np.ndarray:
        """Points p (..., 3) [m] in the box frame."""
        return (np.asarray(p, dtype=float) - np.asarray(self.centre)) @ self.axes

    def contains(self, p: np.ndarray, margin: float = 0.0) -> bool:
        """Whether the point p (3,) [m] lies inside the box shrunk by `margin` [m]."""
        return bool(np.all(np.abs(self.local(p)) <= np.asarray(self.half_extents) - margin))

    def sample(self, rng: np.random.Generator, margin: float = 0.0) -> np.ndarray:
        """A uniform point (3,) [m] of the box shrunk by `margin` [m] (its centre where it is thinner)."""
        h = np.maximum(np.asarray(self.half_extents) - margin, 0.0)
        return np.asarray(self.centre) + self.axes @ rng.uniform(-h, h)

    def moved(self, rotation: np.ndarray, translation: np.ndarray) -> Region:
        """The region moved by x -> rotation (3, 3) @ x + translation (3,) [m]."""
        return replace(
            self,
            centre=_t3(rotation @ np.asarray(self.centre) + translation),
            axes=rotation @ self.axes,
            approach=_t3(rotation @ np.asarray(self.approach)),
        )


@dataclass(frozen=True)
class Surface:
    """A rectangular patch of an outer surface: points centre + a u + b v for a, b in [-1, 1].

    Attributes:
        centre: (3,) [m].
        normal: (3,) unit outward normal (the side a gripper comes from).
        u, v: (3,) half-axis vectors [m] in the surface plane (zero for an edge or a point).
        kind: "edge", "rim", "face", "underside" or "bar".
    """

    centre: tuple[float, float, float]
    normal: tuple[float, float, float]
    u: tuple[float, float, float]
    v: tuple[float, float, float]
    kind: str

    def sample(self, rng: np.random.Generator) -> np.ndarray:
        """A uniform point (3,) [m] of the patch."""
        a, b = rng.uniform(-1.0, 1.0, 2)
        return np.asarray(self.centre) + a * np.asarray(self.u) + b * np.asarray(self.v)

    def moved(self, rotation: np.ndarray, translation: np.ndarray) -> Surface:
        """The patch moved by x -> rotation (3, 3) @ x + translation (3,) [m]."""
        return replace(
            self,
            centre=_t3(rotation @ np.asarray(self.centre) + translation),
            normal=_t3(rotation @ np.asarray(self.normal)),
            u=_t3(rotation @ np.asarray(self.u)),
            v=_t3(rotation @ np.asarray(self.v)),
        )


@dataclass(frozen=True)
class Furniture:
    """One piece of furniture.

    Attributes:
        family: the workcell family that made it ("bookshelf", "bin", "cage", "undershelf", "wall").
        parts: its obstacles.
        regions: free space inside it where goals may go.
        surfaces: patches a pre-grasp pose may face.
        front: (3,) unit horizontal normal of its opening (pointing out of it, towards where a camera should
            stand to look in), `world`.
        anchor: (3,) [m] the centre of its front plane at table height, `world` (the local origin).
    """

    family: str
    parts: tuple[Obstacle, ...]
    regions: tuple[Region, ...]
    surfaces: tuple[Surface, ...]
    front: tuple[float, float, float] = (-1.0, 0.0, 0.0)
    anchor: tuple[float, float, float] = (0.0, 0.0, 0.0)

    def moved(self, rotation: np.ndarray, translation: np.ndarray) -> Furniture:
        """The piece moved by x -> rotation (3, 3) @ x + translation (3,) [m]."""
        rot, tr = np.asarray(rotation, dtype=float), np.asarray(translation, dtype=float)
        return replace(
            self,
            parts=tuple(transformed(p, rot, tr) for p in self.parts),
            regions=tuple(r.moved(rot, tr) for r in self.regions),
            surfaces=tuple(s.moved(rot, tr) for s in self.surfaces),
            front=_t3(rot @ np.asarray(self.front)),
            anchor=_t3(rot @ np.asarray(self.anchor) + tr),
        )


def box_region(lo, hi, approach, kind: str) -> Region:
    """An axis-aligned region between the corners lo (3,) and hi (3,) [m] (local frame of a builder)."""
    lo, hi = np.asarray(lo, dtype=float), np.asarray(hi, dtype=float)
    return Region(_t3((lo + hi) / 2), np.eye(3), _t3((hi - lo) / 2), _t3(approach), kind)


def surface(centre, normal, u=(0, 0, 0), v=(0, 0, 0), kind: str = "face") -> Surface:
    """A Surface from plain sequences (local frame of a builder)."""
    return Surface(_t3(centre), _t3(normal), _t3(u), _t3(v), kind)

"""Small objects to grasp in a workcell: upright boxes and cylinders standing on a support (a shelf board, a bin
floor, the table), with their grasp pose (the TCP at the object's centre, the open fingers across its narrow
side).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import coal
import numpy as np
from scipy.spatial.transform import Rotation

from latent_planner_ros.data.obstacle_geometry import coal_geometry
from latent_planner_ros.data.obstacles import Box, Cylinder, Mesh, Obstacle, quat_xyzw

WIDTH = (0.02, 0.06)
"""[m] range of the narrow side (the fingers open to 8 cm)"""
SIDE_HEIGHT = (0.08, 0.14)
"""[m] heights of objects grasped from the side (the hand's palm and wrist stay clear of the support)"""
TOP_HEIGHT = (0.05, 0.064)
"""[m] heights of objects grasped from above (the fingertips clear the support, the palm clears the top)"""
LIFT = 0.001
"""[m] an object stands this far above its support (so only a grasp, not the support, touches it)"""


@dataclass(frozen=True)
class GraspObject:
    """An object and its grasp.

    Attributes:
        obstacle: its true geometry (a Box or an upright Cylinder).
        tcp_rotation: (3, 3) the grasp's hand orientation (columns x, y, z; z the approach, y across the
            narrow side).
    """

    obstacle: Obstacle
    tcp_rotation: np.ndarray

    @property
    def centre(self) -> np.ndarray:
        if isinstance(self.obstacle, Mesh):
            raise TypeError("a grasp object is a box or a cylinder, not a mesh")
        return np.asarray(self.obstacle.position, dtype=float)


def hand_rotation(approach: np.ndarray, across: np.ndarray) -> np.ndarray:
    """The hand orientation (3, 3) with z along approach (3,) and y along across (3,) (made orthogonal)."""
    z = np.asarray(approach, dtype=float) / np.linalg.norm(approach)
    y = np.asarray(across, dtype=float) - z * float(np.dot(across, z))
    y /= np.linalg.norm(y)
    return np.stack([np.cross(y, z), y, z], 1)


def draw_object(
    rng: np.random.Generator,
    xy: np.ndarray,
    support_z: float,
    approach: np.ndarray,
    tilt_deg: float = 10.0,
    long_axis: np.ndarray | None = None,
) -> GraspObject:
    """An upright object standing at xy (2,) [m] on a support at height support_z [m], grasped along approach
    (3,): from above when approach points down (> 45 deg), else from the side, its narrow side across it. From
    above, the fingers close along long_axis (3,) (within tilt_deg; a random direction when None): the hand is
    long across the fingers, so it fits a narrow bin that way."""
    approach = np.asarray(approach, dtype=float) / np.linalg.norm(approach)
    top = approach[2] < -math.sqrt(0.5)
    width = rng.uniform(*WIDTH)
    depth = rng.uniform(width, WIDTH[1])
    height = rng.uniform(*(TOP_HEIGHT if top else SIDE_HEIGHT))
    if top and long_axis is not None:
        yaw = math.atan2(long_axis[1], long_axis[0]) + math.radians(rng.uniform(-tilt_deg, tilt_deg))
        z = np.array([0.0, 0.0, -1.0])
    elif top:
        yaw = rng.uniform(-math.pi, math.pi)
        z = np.array([0.0, 0.0, -1.0])
    else:
        yaw = math.atan2(approach[1], approach[0]) + math.radians(rng.uniform(-tilt_deg, tilt_deg))
        z = np.array([math.cos(yaw), math.sin(yaw), 0.0])
    across = np.array([-math.sin(yaw), math.cos(yaw), 0.0]) if not top else np.array([math.cos(yaw), math.sin(yaw), 0])
    centre = (float(xy[0]), float(xy[1]), float(support_z + LIFT + height / 2))
    if rng.random() < 0.5:
        obstacle: Obstacle = Cylinder(centre, (0.0, 0.0, 0.0, 1.0), width / 2, height / 2)
    else:
        # box axes: x along the approach's horizontal direction (depth), y across (width)
        heading = math.atan2(across[1], across[0]) - math.pi / 2
        quat = Rotation.from_euler("z", heading).as_quat()
        obstacle = Box(centre, quat_xyzw(quat), (depth / 2, width / 2, height / 2))
    x_sign = 1.0 if rng.random() < 0.5 else -1.0
    rot = hand_rotation(z, x_sign * across)
    return GraspObject(obstacle, rot)


def clearance_except_support(obstacle: Obstacle, others: Sequence[Obstacle], support_z: float) -> float:
    """The smallest distance [m] from obstacle to the others, ignoring contacts at or below support_z + 2 mm (its
    support); inf without others."""
    geom, tf = coal_geometry(obstacle)
    request, result = coal.DistanceRequest(), coal.DistanceResult()
    best = math.inf
    for o in others:
        g, t = coal_geometry(o)
        result.clear()
        d = coal.distance(geom, tf, g, t, request, result)
        if float(np.asarray(result.getNearestPoint2())[2]) <= support_z + 0.002 and d < 0.01:
            continue
        best = min(best, float(d))
    return best

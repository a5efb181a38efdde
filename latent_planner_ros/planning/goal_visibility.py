"""Is a goal hidden just behind an observed surface? Then it is probably inside the object the surface belongs to.

A depth camera sees an object's near side only. A goal at the centre of a cylinder is several centimetres from
every observed point, so the closed loop's clearance rule (`goal_clearance_m`) takes it, and the arm is then driven
into the side no camera saw. This module looks along each camera's line of sight to the goal: a camera whose ray
to the goal meets an observed point less than `depth` before the goal sees the goal *hidden*; a camera whose ray
meets nothing before the goal and observed points beyond it sees *through* the goal's position (it is free). A
goal hidden from some camera and seen through by none is refused. Pure numpy.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

LATERAL_M = 0.015
"""[m] an observed point within this distance of a line of sight is on it (above the clouds' 1 cm voxels)"""
NEAR_GOAL_M = 0.01
"""[m] points this close to the goal along the ray are the clearance rule's business, not hiding it"""


@dataclass(frozen=True)
class GoalView:
    """What the cameras see of a goal position.

    Attributes:
        hidden_by: cameras whose line of sight meets an observed surface less than the depth before the goal.
        seen_through: cameras that see past the goal's position (nothing before it, a return beyond).
        depth_m: the shortest distance [m] from a hiding surface point to the goal along its ray (inf if none).
    """

    hidden_by: int
    seen_through: int
    depth_m: float

    @property
    def hidden(self) -> bool:
        """Hidden from a camera within the depth and seen through by none."""
        return self.hidden_by > 0 and self.seen_through == 0


def goal_view(position: np.ndarray, cloud: np.ndarray, eyes: np.ndarray, depth_m: float) -> GoalView:
    """How the cameras at `eyes` (K, 3) [m] see the goal `position` (3,) [m] in the observed cloud (N, 3) [m].

    Args:
        position: the goal's TCP position in the cloud's frame.
        cloud: observed points (finite rows).
        eyes: optical centres of the cameras the cloud was fused from (non-finite rows are skipped).
        depth_m: [m] a surface point on the line of sight this far or less before the goal hides it.
    """
    g = np.asarray(position, dtype=float).reshape(3)
    cloud = np.asarray(cloud, dtype=float).reshape(-1, 3)
    hidden_by = seen_through = 0
    depth = np.inf
    for eye in np.asarray(eyes, dtype=float).reshape(-1, 3):
        if not np.all(np.isfinite(eye)):
            continue
        ray = g - eye
        dist = float(np.linalg.norm(ray))
        if dist < 1e-6:
            continue
        ray /= dist
        v = cloud - eye
        along = v @ ray
        lateral_sq = np.einsum("ij,ij->i", v, v) - along * along  # squared distance to the line of sight
        on_ray = (lateral_sq < LATERAL_M * LATERAL_M) & (along > 0.0)
        before = on_ray & (along < dist - NEAR_GOAL_M)
        if before.any():
            gap = dist - float(along[before].max())
            if gap <= depth_m:
                hidden_by += 1
                depth = min(depth, gap)
        elif (on_ray & (along > dist + NEAR_GOAL_M)).any():
            seen_through += 1
    return GoalView(hidden_by, seen_through, depth)

"""The caller's side of a grasp goal's target, shared by the planner nodes: a CUBE marker on `grasp_target`
(msg_adapters/target_box.py) latched as a box, else the `grasp_target_radius_m` parameter, else the object is found
in the cloud (perception/grasp_target.py)."""

from __future__ import annotations

import numpy as np
from visualization_msgs.msg import Marker

from latent_planner_ros.perception.grasp_target import TargetBox
from latent_planner_ros.planning.grasp import GraspSpec
from msg_adapters import marker_to_box
from msg_adapters.pose import pose_stamped_in_base


class GraspTargetInput:
    """The latched target box (in the robot base frame) of the grasp goals that follow, or None."""

    def __init__(self):
        self.box: TargetBox | None = None

    def on_marker(self, msg: Marker, frames) -> None:
        """Take a marker (see msg_adapters.target_box): a CUBE sets the box, DELETE / DELETEALL clears it.
        Raises AdapterError (the box stays as it was) for a marker it refuses; frames: perception.frames.Frames."""
        got = marker_to_box(msg)
        if got is None:
            self.box = None
            return
        pose, half = got
        target = pose_stamped_in_base(pose, frames)
        self.box = TargetBox(np.array(target.position), np.array(target.rotation), half)

    def spec(self, approach_m: float, radius_m: float) -> GraspSpec:
        """The GraspSpec of the next grasp goal: the box if one is set, else radius_m [m] (0: found in the cloud)."""
        if self.box is not None:
            return GraspSpec(approach_m, None, self.box)
        return GraspSpec(approach_m, radius_m or None)

    def describe(self, radius_m: float) -> str:
        """How the next grasp goal's target is chosen, for a status topic."""
        if self.box is not None:
            c, e = self.box.centre, 200.0 * self.box.half_extents
            return (f"box {e[0]:.0f} x {e[1]:.0f} x {e[2]:.0f} cm at ({c[0]:.3f}, {c[1]:.3f}, {c[2]:.3f}) m "
                    "(grasp_target)")  # fmt: skip
        if radius_m:
            return f"points within {radius_m * 100:g} cm of the TCP (grasp_target_radius_m)"
        return "found in the cloud"

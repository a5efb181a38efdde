"""Valid ranges of the planning configs' fields, for the parameter descriptors (latent_planner_ros/params/specs.py).

One table per config class, in the notation of docs/nodes.md; each range is the one the config's own
validation enforces (test/nodes/test_param_ranges.py probes both ends of every entry). Fields whose validation
is not a plain range (choices, cross-field rules) are not listed.
"""

from __future__ import annotations

from latent_planner_ros.planning.ik import IkConfig
from latent_planner_ros.planning.motion_limits import MotionLimits
from latent_planner_ros.planning.ompl_baseline_config import OmplConfig

OMPL = {
    **dict.fromkeys(
        ("timeout_s", "anytime_budget_s", "octree_resolution", "simplify_time_s", "waypoint_step_deg"), "> 0"
    ),
    "padding": ">= 0",
    "range_rad": ">= 0",
    "check_step_deg": "[0.01, 10]",
    "speed_scale": "(0, 1]",
}

IK = {
    **dict.fromkeys(("n_seeds", "max_solutions", "max_iters"), ">= 1"),
    "stall_iters": ">= 0",
    **dict.fromkeys(("damping", "max_step_rad", "pos_tol", "ori_tol_deg", "min_separation_rad", "timeout_s"), "> 0"),
}

MOTION = dict.fromkeys(("velocity_scale", "acceleration_scale", "jerk_scale"), "(0, 1]")

PLANNING_RANGES = {
    OmplConfig: OMPL,
    IkConfig: IK,
    MotionLimits: MOTION,
}
"""{config class: {field: range}} of the planning configs."""

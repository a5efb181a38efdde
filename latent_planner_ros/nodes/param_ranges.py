"""Valid ranges of the planning configs' fields, for the parameter descriptors (sim_bridge/param_specs.py).

One table per config class, in the notation of docs/nodes.md; each range is the one the config's own
validation enforces (test/nodes/test_param_ranges.py probes both ends of every entry). Fields whose validation
is not a plain range (choices, cross-field rules) are not listed.
"""

from __future__ import annotations

from latent_planner_ros.planning.amp_ls_config import AmpLsConfig
from latent_planner_ros.planning.closed_loop import ClosedLoopConfig
from latent_planner_ros.planning.ik import IkConfig
from latent_planner_ros.planning.motion_limits import MotionLimits
from latent_planner_ros.planning.ompl_baseline_config import OmplConfig

CLOSED_LOOP = {
    **dict.fromkeys(
        ("rate_hz", "stale_joint_states_s", "stale_scene_s", "tick_budget_ms", "no_progress_s", "progress_m"), "> 0"
    ),
    "reach_m": "> 0",
    "max_iterations_per_tick": "[1, 100]",
    "accepted_steps_per_tick": "[1, 100]",
    **dict.fromkeys(
        ("goal_clearance_m", "goal_lead_s", "goal_lead_max_m", "evade_margin_m", "evade_approach_mps"), ">= 0"
    ),
    "plan_wait_s": ">= 0",
    "replan_after_s": "> 0",
    "follow_goal_tol_m": "> 0",
    "servo_radius_m": ">= 0",
    "servo_max_rad": ">= 0",
    "servo_clearance_m": ">= 0",
}

AMP_LS = {
    **dict.fromkeys(
        ("lr", "plan_lr", "pos_tol", "ori_tol_deg", "finish_ik_step_rad", "seed_noise", "lambda_min", "lambda_max"),
        "> 0",
    ),
    "restart_scale": "> 0",
    **dict.fromkeys(
        ("max_steps", "interp_steps", "finish_ik_iters", "finish_every", "n_seeds", "closed_loop_seeds", "patience"),
        ">= 1",
    ),
    **dict.fromkeys(
        (
            "finish_radius_m",
            "finish_angle_deg",
            "finish_max_rad",
            "escape_rad",
            "rrt_escape_budget_s",
            "rrt_escape_after_s",
            "timeout_s",
            "finish_ik_stall",
            "goal_guidance",
            "restarts",
        ),
        ">= 0",
    ),
    "col_threshold": "(0, 1)",
    "backtrace_keep": "[0, 1)",
    "geco_alpha_ma": "[0, 1)",
    "check_step_rad": "[0, 0.5]",
    "speed_scale": "(0, 1]",
}

OMPL = {
    **dict.fromkeys(
        ("timeout_s", "anytime_budget_s", "octree_resolution", "simplify_time_s", "waypoint_step_deg"), "> 0"
    ),
    "padding": ">= 0",
    "range_rad": ">= 0",
    "check_step_deg": "(0, 10]",
    "speed_scale": "(0, 1]",
}

IK = {
    **dict.fromkeys(("n_seeds", "max_solutions", "max_iters"), ">= 1"),
    "stall_iters": ">= 0",
    **dict.fromkeys(("damping", "max_step_rad", "pos_tol", "ori_tol_deg", "min_separation_rad", "timeout_s"), "> 0"),
}

MOTION = dict.fromkeys(("velocity_scale", "acceleration_scale", "jerk_scale"), "(0, 1]")

PLANNING_RANGES = {
    ClosedLoopConfig: CLOSED_LOOP,
    AmpLsConfig: AMP_LS,
    OmplConfig: OMPL,
    IkConfig: IK,
    MotionLimits: MOTION,
}
"""{config class: {field: range}} of the planning configs."""

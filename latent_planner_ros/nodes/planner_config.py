"""Parameters of the planner node: one dataclass, mapped 1:1 onto ROS parameters (config/planner.yaml)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from latent_planner_ros.nodes.frames_config import FRAMES_READ_ONLY, FramesConfig
from latent_planner_ros.nodes.param_ranges import PLANNING_RANGES
from latent_planner_ros.nodes.scene_encoder_config import check_topics
from latent_planner_ros.planning.amp_ls_config import AmpLsConfig
from latent_planner_ros.planning.closed_loop import ClosedLoopConfig
from latent_planner_ros.planning.cylinder_backend import CHECKS
from latent_planner_ros.planning.lspp import lspp_config
from latent_planner_ros.planning.motion_limits import MotionLimits
from sim_bridge.params import ConfigError


@dataclass
class PlannerNodeConfig:
    enabled: bool = False
    """track the goal in closed loop from the start (the enable service switches it); enabling claims the arm
    on `execution_owner` (ompl_planner's execution stops)"""
    vae_checkpoint: str = ""
    """VAE checkpoint stem; empty = the shipped default"""
    collision_checkpoint: str = ""
    """collision-predictor checkpoint stem (learned backend); empty = the shipped default for planning
    (checkpoints/collision_distilled)"""
    lspp_checkpoint: str = ""
    """LSPP obstacle-classifier checkpoint stem (cylinder obstacles on `obstacles`); empty = the shipped default"""
    lspp_check: str = "exact"
    """LSPP's hard check of interpolated states: "exact" (meshes vs the cylinders) or "none" (the seed's)"""
    obstacle_tilt_tol_deg: float = 2.0
    """largest tilt [deg] of a cylinder marker's axis from the vertical; more is refused"""
    obstacle_z_tol_m: float = 0.01
    """largest difference [m] between a cylinder marker's pose.position.z and scale.z / 2 (standing on z = 0)"""
    cloud_max_points: int = 100_000
    """camera/points clouds with more finite points are voxel-downsampled to at most this many (bounded tick time)"""
    cloud_voxel_m: float = 0.01
    """[m] first voxel edge of that downsampling (grown until the cloud fits); 0 = keep evenly spaced points"""
    status_rate_hz: float = 2.0
    """status publishing rate [Hz]"""
    cloud_topics: tuple[str, ...] = ("camera/points",)
    """the cloud topics (one per camera; frames as `frames` accepts) fused for the geometric backend, the hard check
    and the goal checks; fixed at start-up"""
    cloud_max_age_s: float = 0.5
    """[s] a topic's newest cloud stamped further than this from the newest cloud is left out as stale; 0 = never"""
    grasp_approach_m: float = 0.08
    """[m] ~/plan_grasp: plan to the pre-grasp this far back along the hand's z axis, then approach straight
    (planning/grasp.py); 0 = plan to the grasp directly, target points set aside"""
    grasp_target_radius_m: float = 0.0
    """[m] ~/plan_grasp: the target is every cloud point within this of the grasp goal's TCP; 0 = find the object
    in the cloud (the closing region's points grown through connected points, perception/grasp_target.py)"""
    frames: FramesConfig = field(default_factory=FramesConfig)
    limits: MotionLimits = field(default_factory=MotionLimits)
    """fractions of the Panda's velocity, acceleration and jerk limits the published trajectories use (the closed
    loop's segments on joint_trajectory and the plans on ~/trajectory)"""
    closed_loop: ClosedLoopConfig = field(default_factory=ClosedLoopConfig)
    amp_ls: AmpLsConfig = field(default_factory=AmpLsConfig)
    lspp: AmpLsConfig = field(default_factory=lspp_config)
    """the planner used while cylinder obstacles are set (position-only goals)"""

    def __post_init__(self) -> None:
        if not (isinstance(self.status_rate_hz, int | float) and 0 < self.status_rate_hz <= 100):
            raise ValueError(f"status_rate_hz must be in (0, 100], got {self.status_rate_hz!r}")
        n = self.cloud_max_points
        if not (isinstance(n, int) and not isinstance(n, bool) and 1_000 <= n <= 10_000_000):
            raise ValueError(f"cloud_max_points must be an integer in [1000, 10000000], got {n!r}")
        try:
            check_topics("cloud_topics", self.cloud_topics)
        except ConfigError as err:
            raise ValueError(str(err)) from None
        r = self.grasp_target_radius_m
        if not (isinstance(r, int | float) and not isinstance(r, bool) and math.isfinite(r) and 0 <= r <= 0.2):
            raise ValueError(f"grasp_target_radius_m must be a number in [0, 0.2], got {r!r}")
        g = self.grasp_approach_m
        if not (isinstance(g, int | float) and not isinstance(g, bool) and math.isfinite(g) and 0 <= g <= 0.3):
            raise ValueError(f"grasp_approach_m must be a number in [0, 0.3], got {g!r}")
        c = self.cloud_max_age_s
        if not (isinstance(c, int | float) and not isinstance(c, bool) and math.isfinite(c) and 0 <= c <= 3600):
            raise ValueError(f"cloud_max_age_s must be a number in [0, 3600], got {c!r}")
        if self.lspp_check not in CHECKS:
            raise ValueError(f"lspp_check must be one of {CHECKS}, got {self.lspp_check!r}")
        for name, high in (("obstacle_tilt_tol_deg", 45.0), ("obstacle_z_tol_m", 1.0), ("cloud_voxel_m", 0.5)):
            v = getattr(self, name)
            if not (isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v) and 0 <= v <= high):
                raise ValueError(f"{name} must be a number in [0, {high}], got {v!r}")
        lspp = self.lspp
        required = {
            "lspp.collision_backend": lspp.collision_backend == "cylinders",
            "lspp.use_collision": lspp.use_collision,
            "lspp.use_orientation": not lspp.use_orientation,
        }
        wrong = [name for name, ok in required.items() if not ok]
        if wrong:
            raise ValueError(
                f"{wrong[0]}: lspp must plan around the cylinders with position-only goals "
                "(lspp.collision_backend = cylinders, lspp.use_collision = true, lspp.use_orientation = false)"
            )


RANGES = {
    **PLANNING_RANGES,
    PlannerNodeConfig: {
        "obstacle_tilt_tol_deg": "[0, 45]",
        "obstacle_z_tol_m": "[0, 1]",
        "cloud_max_points": "[1000, 10000000]",
        "cloud_voxel_m": "[0, 0.5]",
        "status_rate_hz": "(0, 100]",
        "cloud_max_age_s": "[0, 3600]",
        "grasp_approach_m": "[0, 0.3]",
        "grasp_target_radius_m": "[0, 0.2]",
    },
}
"""Valid ranges of the planner's parameters (sim_bridge/param_specs.py), as the validation enforces them."""

READ_ONLY = ("cloud_topics", *FRAMES_READ_ONLY)
"""Parameters fixed at start-up (subscriptions and frames)."""

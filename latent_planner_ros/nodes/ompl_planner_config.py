"""Parameters of the ompl_planner node: one dataclass, mapped 1:1 onto ROS parameters (config/ompl_planner.yaml)."""

from __future__ import annotations

from dataclasses import dataclass, field

from latent_planner_ros.nodes.frames_config import FRAMES_READ_ONLY, FramesConfig
from latent_planner_ros.nodes.param_ranges import PLANNING_RANGES
from latent_planner_ros.nodes.scene_encoder_config import check_topics
from latent_planner_ros.params.config import MIN_RATE_HZ, ConfigError, check_number
from latent_planner_ros.planning.motion_limits import MotionLimits
from latent_planner_ros.planning.ompl_baseline_config import OmplConfig


@dataclass
class OmplPlannerNodeConfig:
    execute: bool = False
    """send each successful plan's trajectory on joint_trajectory; turning it on claims the arm on
    `execution_owner` (the planner's closed loop is disabled)"""
    stale_joint_states_s: float = 0.5
    """joint states older than this [s] refuse plans"""
    require_cloud: bool = True
    """refuse plans until a point cloud has arrived (False: plan against an empty occupancy map)"""
    pos_tol: float = 0.01
    """goal position tolerance [m] when a request's tolerance is 0"""
    ori_tol_deg: float = 15.0
    """goal orientation tolerance [deg]"""
    status_rate_hz: float = 2.0
    """status publishing rate [Hz]"""
    cloud_topics: tuple[str, ...] = ("camera/points",)
    """the cloud topics (one per camera; frames as `frames` accepts) fused into the occupancy map; fixed at start-up"""
    cloud_max_age_s: float = 0.5
    """[s] a topic's newest cloud stamped further than this from the newest cloud is left out as stale; 0 = never"""
    grasp_approach_m: float = 0.08
    """[m] ~/plan_grasp: plan to the pre-grasp this far back along the hand's z axis, then approach straight
    (planning/grasp.py, as the planner node); 0 = plan to the grasp directly, target points set aside"""
    grasp_target_radius_m: float = 0.0
    """[m] ~/plan_grasp: the target is every cloud point within this of the grasp goal's TCP; 0 = find the object
    in the cloud (the closing region's points grown through connected points, perception/grasp_target.py)"""
    frames: FramesConfig = field(default_factory=FramesConfig)
    limits: MotionLimits = field(default_factory=MotionLimits)
    """fractions of the Panda's velocity, acceleration and jerk limits the plans' trajectories use"""
    ompl: OmplConfig = field(default_factory=OmplConfig)

    def __post_init__(self) -> None:
        for name in ("execute", "require_cloud"):
            if not isinstance(getattr(self, name), bool):
                raise ConfigError(f"{name}: expected true or false, got {getattr(self, name)!r}")
        check_number("stale_joint_states_s", self.stale_joint_states_s, 0.0, 60.0, open_low=True)
        check_number("pos_tol", self.pos_tol, 0.0, 1.0, open_low=True)
        check_number("ori_tol_deg", self.ori_tol_deg, 0.0, 180.0, open_low=True)
        check_number("status_rate_hz", self.status_rate_hz, MIN_RATE_HZ, 100.0)
        check_topics("cloud_topics", self.cloud_topics)
        check_number("cloud_max_age_s", self.cloud_max_age_s, 0.0, 3600.0)
        check_number("grasp_approach_m", self.grasp_approach_m, 0.0, 0.3)
        check_number("grasp_target_radius_m", self.grasp_target_radius_m, 0.0, 0.2)


RANGES = {
    **PLANNING_RANGES,
    OmplPlannerNodeConfig: {
        "stale_joint_states_s": "(0, 60]",
        "pos_tol": "(0, 1]",
        "ori_tol_deg": "(0, 180]",
        "status_rate_hz": "[0.01, 100]",
        "cloud_max_age_s": "[0, 3600]",
        "grasp_approach_m": "[0, 0.3]",
        "grasp_target_radius_m": "[0, 0.2]",
    },
}
"""Valid ranges of the ompl_planner's parameters, as the validation enforces them."""

READ_ONLY = ("cloud_topics", *FRAMES_READ_ONLY)
"""Parameters fixed at start-up (subscriptions and frames)."""

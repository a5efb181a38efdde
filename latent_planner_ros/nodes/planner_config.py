"""Parameters of the planner node: the settings a user tunes, mapped 1:1 onto ROS parameters (config/planner.yaml).

AMP-LS and LSPP are chosen by preset (planning/amp_ls/presets.py) with the tuned settings applied over it; the
closed loop's and the planners' other settings keep the defaults of their config classes, or come from the
`tuning_file` (nodes/planner_tuning.py). Defaults live in the config classes: the fields below take theirs.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from latent_planner_ros.nodes.frames_config import FRAMES_READ_ONLY, FramesConfig
from latent_planner_ros.nodes.param_ranges import PLANNING_RANGES
from latent_planner_ros.nodes.planner_tuning import load_tuning
from latent_planner_ros.nodes.scene_encoder_config import check_topics
from latent_planner_ros.params.config import MIN_RATE_HZ, ConfigError
from latent_planner_ros.planning.amp_ls import AmpLsConfig, PlanConfig, SearchConfig, presets
from latent_planner_ros.planning.amp_ls.config import with_overrides
from latent_planner_ros.planning.closed_loop import ClosedLoopConfig
from latent_planner_ros.planning.cylinder_backend import CHECKS
from latent_planner_ros.planning.motion_limits import MotionLimits

AMP_LS_PRESETS = ("default", "seed")
"""presets.PRESETS of the AMP-LS planners (LSPP's: LSPP_PRESETS)"""
LSPP_PRESETS = ("lspp", "lspp_seed")


@dataclass
class AmpLsParams:
    """AMP-LS on the node: a preset and the settings applied over it (the rest: the preset's, or tuning_file)."""

    preset: str = "default"
    """"default" (every part beyond the seed on) or "seed" (the seed's Algorithm 1: no exact finish, guidance,
    RRT escape, shortcuts or lazy checks); the parameters below apply over it"""
    collision_backend: str = AmpLsConfig.collision_backend
    """"learned" (scene embeddings + the collision predictor), "geometric" (arm spheres vs the cloud), "local" (the
    local collision network: the cloud points next to each link) or "none\""""
    lr: float = AmpLsConfig.lr
    """[latent units] step size of the closed loop's latent optimisation"""
    plan_lr: float = SearchConfig.plan_lr
    """[latent units] step size of one-shot plans (~/plan, background plans)"""
    pos_tol: float = AmpLsConfig.pos_tol
    """[m] position tolerance of goals"""
    ori_tol_deg: float = AmpLsConfig.ori_tol_deg
    """[deg] orientation tolerance of goals"""
    col_threshold: float = AmpLsConfig.col_threshold
    """gamma_col: a decoded state with p(collision) at or above this is not accepted"""
    n_seeds: int = SearchConfig.n_seeds
    """latent seeds optimised together in a one-shot plan"""
    timeout_s: float = PlanConfig.timeout_s
    """[s] a one-shot plan gives up after this wall time; 0 = its step budget alone"""

    def __post_init__(self) -> None:
        if self.preset not in AMP_LS_PRESETS:
            raise ValueError(f"preset must be one of {AMP_LS_PRESETS}, got {self.preset!r}")
        self.config()  # ValueError naming what AmpLsConfig refuses

    def overrides(self) -> dict:
        """These settings as AmpLsConfig overrides."""
        return {
            "collision_backend": self.collision_backend,
            "lr": self.lr,
            "search.plan_lr": self.plan_lr,
            "pos_tol": self.pos_tol,
            "ori_tol_deg": self.ori_tol_deg,
            "col_threshold": self.col_threshold,
            "search.n_seeds": self.n_seeds,
            "plan.timeout_s": self.timeout_s,
        }

    def config(self, tuning: dict | None = None) -> AmpLsConfig:
        """The AmpLsConfig: the preset, the tuning file's amp_ls section, these settings."""
        return _layered(presets.get(self.preset), tuning or {}, self.overrides(), "amp_ls")


@dataclass
class LsppParams:
    """LSPP (cylinder obstacles on `obstacles`) on the node: its preset (the rest: tuning_file)."""

    preset: str = "lspp"
    """"lspp" (32 seeds, 192 restarts, exact checks) or "lspp_seed" (the seed's: one trajectory, 300 steps)"""

    def __post_init__(self) -> None:
        if self.preset not in LSPP_PRESETS:
            raise ValueError(f"lspp.preset must be one of {LSPP_PRESETS}, got {self.preset!r}")

    def config(self, tuning: dict | None = None) -> AmpLsConfig:
        """The AmpLsConfig: the preset, then the tuning file's lspp section; ValueError unless it plans around
        the cylinders with position-only goals."""
        cfg = _layered(presets.get(self.preset), tuning or {}, {}, "lspp")
        if cfg.collision_backend != "cylinders" or not cfg.use_collision or cfg.use_orientation:
            raise ValueError(
                "lspp must plan around the cylinders with position-only goals "
                "(collision_backend = cylinders, use_collision = true, use_orientation = false)"
            )
        return cfg


@dataclass
class ClosedLoopParams:
    """The closed loop's tuned settings (planning/closed_loop.py ClosedLoopConfig; the rest: tuning_file)."""

    rate_hz: float = ClosedLoopConfig.rate_hz
    """[Hz] control rate: one tick (optimisation steps, a checked command) per period"""
    max_iterations_per_tick: int = ClosedLoopConfig.max_iterations_per_tick
    """latent optimisation steps a tick may take"""
    tick_budget_ms: float = ClosedLoopConfig.tick_budget_ms
    """[ms] a tick starts no further step that would likely end past this"""
    stale_scene_s: float = ClosedLoopConfig.stale_scene_s
    """[s] a scene older than this holds the arm"""
    no_progress_s: float = ClosedLoopConfig.no_progress_s
    """[s] a goal the arm gets no closer to for this long is given up"""
    goal_lead_s: float = ClosedLoopConfig.goal_lead_s
    """[s] chase a moving goal this far ahead (its velocity x this); 0 = off"""
    evade_margin_m: float = ClosedLoopConfig.evade_margin_m
    """[m] a holding arm retreats from obstacles approaching nearer than this; 0 = off"""
    follow_plans: bool = ClosedLoopConfig.follow_plans
    """still goals: plan in the background and follow the path; false = local steps only"""
    servo_radius_m: float = ClosedLoopConfig.servo_radius_m
    """[m] within this of a moving goal, servo by hard-checked IK; 0 = off"""

    def config(self, tuning: dict | None = None) -> ClosedLoopConfig:
        """The ClosedLoopConfig: these settings over the tuning file's closed_loop section."""
        ours = {name: getattr(self, name) for name in self.__dataclass_fields__}
        tuned = dict(tuning or {})
        clash = sorted(set(tuned) & set(ours))
        if clash:
            raise ValueError(f"tuning_file closed_loop: {clash[0]} is a parameter of the node: set it there")
        return ClosedLoopConfig(**tuned, **ours)

    def __post_init__(self) -> None:
        self.config()  # ValueError naming what ClosedLoopConfig refuses


def _layered(base: AmpLsConfig, tuning: dict, params: dict, section: str) -> AmpLsConfig:
    """base with the tuning file's section, then the node's parameters, applied."""
    clash = sorted(set(tuning) & set(params))
    if clash:
        raise ValueError(f"tuning_file {section}: {clash[0]} is set by a parameter of the node: set it there")
    return with_overrides(with_overrides(base, tuning), params)


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
    plan_process: bool = True
    """run the closed loop's background plans in a child process (planning/plan_process.py): a plan then never
    shares the control loop's interpreter; false = on a thread of the node; fixed at start-up"""
    tuning_file: str = ""
    """a YAML of the settings that are not parameters (nodes/planner_tuning.py); empty = their defaults; fixed at
    start-up"""
    frames: FramesConfig = field(default_factory=FramesConfig)
    limits: MotionLimits = field(default_factory=MotionLimits)
    """fractions of the Panda's velocity, acceleration and jerk limits the published trajectories use (the closed
    loop's segments on joint_trajectory and the plans on ~/trajectory)"""
    closed_loop: ClosedLoopParams = field(default_factory=ClosedLoopParams)
    amp_ls: AmpLsParams = field(default_factory=AmpLsParams)
    lspp: LsppParams = field(default_factory=LsppParams)
    """the planner used while cylinder obstacles are set (position-only goals)"""

    def __post_init__(self) -> None:
        if not (isinstance(self.status_rate_hz, int | float) and MIN_RATE_HZ <= self.status_rate_hz <= 100):
            raise ValueError(f"status_rate_hz must be in [{MIN_RATE_HZ}, 100], got {self.status_rate_hz!r}")
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
        v = self.cloud_voxel_m
        if not (isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v) and 0 <= v <= 0.5):
            raise ValueError(f"cloud_voxel_m must be a number in [0, 0.5], got {v!r}")
        self.tuning = load_tuning(self.tuning_file)
        """the tuning file's settings (PlannerTuning)"""
        self.amp_ls_config()  # ValueError naming what the planners' configurations refuse
        self.lspp_config()
        self.closed_loop_config()

    def amp_ls_config(self) -> AmpLsConfig:
        """The AMP-LS planners' configuration."""
        return self.amp_ls.config(self.tuning.amp_ls)

    def lspp_config(self) -> AmpLsConfig:
        """The LSPP planner's configuration."""
        return self.lspp.config(self.tuning.lspp)

    def closed_loop_config(self) -> ClosedLoopConfig:
        """Both closed loops' configuration."""
        return self.closed_loop.config(self.tuning.closed_loop)


RANGES = {
    **PLANNING_RANGES,
    AmpLsParams: {
        **dict.fromkeys(("lr", "plan_lr", "pos_tol", "ori_tol_deg"), "> 0"),
        "col_threshold": "(0, 1)",
        "n_seeds": ">= 1",
        "timeout_s": ">= 0",
    },
    ClosedLoopParams: {
        "rate_hz": ">= 0.01",
        **dict.fromkeys(("tick_budget_ms", "stale_scene_s", "no_progress_s"), "> 0"),
        "max_iterations_per_tick": "[1, 100]",
        **dict.fromkeys(("goal_lead_s", "evade_margin_m", "servo_radius_m"), ">= 0"),
    },
    PlannerNodeConfig: {
        "cloud_max_points": "[1000, 10000000]",
        "cloud_voxel_m": "[0, 0.5]",
        "status_rate_hz": "[0.01, 100]",
        "cloud_max_age_s": "[0, 3600]",
        "grasp_approach_m": "[0, 0.3]",
        "grasp_target_radius_m": "[0, 0.2]",
    },
}
"""Valid ranges of the planner's parameters (latent_planner_ros/params/specs.py), as the validation enforces them."""

READ_ONLY = ("cloud_topics", "tuning_file", "plan_process", *FRAMES_READ_ONLY)
"""Parameters fixed at start-up (subscriptions, frames, where background plans run)."""

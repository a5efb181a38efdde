"""Configuration of the OMPL baseline (seed chapter 7 section V-B: MoveIt's OMPL planners on an occupancy map)."""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field

from latent_planner_ros.planning.ik import IkConfig

PLANNERS: dict[str, tuple[str, bool]] = {
    "rrtconnect": ("RRTConnect", False),
    "rrtstar": ("RRTstar", True),
    "prmstar": ("PRMstar", True),
    "lbkpiece": ("LBKPIECE1", False),
    "bitstar": ("BITstar", True),
}
"""Our planner name -> (OMPL class in ompl.geometric, anytime). Anytime planners use the whole fixed budget;
the others stop at their first solution. PRMstar stands in for LazyPRMstar, which the wheels do not bind."""


MIN_CHECK_STEP_DEG = 0.01
"""finest motion-check step [deg]: OMPL refuses a resolution that rounds to nothing"""


@dataclass
class OmplConfig:
    """Every field maps 1:1 onto a ROS parameter of the ompl_planner node (prefix ``ompl.``)."""

    planner: str = "rrtconnect"
    """one of PLANNERS: rrtconnect, rrtstar, prmstar, lbkpiece, bitstar"""
    timeout_s: float = 5.0
    """RRTConnect / LBKPIECE1: give up without a first solution after this [s] (MoveIt's default)"""
    anytime_budget_s: float = 1.0
    """RRTstar / PRMstar / BITstar: fixed planning time [s] (the seed's 1 s budget)"""
    octree_resolution: float = 0.01
    """occupancy map voxel edge [m]: 1 cm, since 2 cm voxels (MoveIt's usual 2.5 cm alike) refuse goals 1.5-4 cm
    from a surface (a shelf slot, a bin: 10 of 60 goal configurations of the shipped workcell set)"""
    min_z: float = 0.015
    """cloud points below this height [m] are dropped (the table is checked exactly)"""
    padding: float = 0.0
    """clearance [m] the links must keep from occupied voxels"""
    table: bool = True
    """check collisions with the table half-space z < 0"""
    check_step_deg: float = 1.0
    """motion validation resolution: largest joint-space (Euclidean) step between checked states [deg]"""
    range_rad: float = 0.0
    """maximum extension of tree planners [rad]; 0 = OMPL's default (a fifth of the space's extent)"""
    simplify: bool = True
    """shortcut and smooth the solution (OMPL PathSimplifier, MoveIt's default)"""
    simplify_time_s: float = 0.5
    """time budget of the simplification [s]"""
    waypoint_step_deg: float = 3.0
    """the returned path is densified so no joint moves more than this between waypoints [deg]"""
    speed_scale: float = 0.5
    """fraction of the joint velocity limits used by the time parameterisation"""
    seed: int = 0
    """seed of the IK seeds (OMPL's own sampler is seeded once per process with seed_ompl)"""
    ik: IkConfig = field(default_factory=IkConfig)

    def __post_init__(self) -> None:
        problems = []
        if self.planner not in PLANNERS:
            problems.append(f"planner must be one of {tuple(PLANNERS)}, got {self.planner!r}")
        for name in (
            "timeout_s",
            "anytime_budget_s",
            "octree_resolution",
            "check_step_deg",
            "simplify_time_s",
            "waypoint_step_deg",
            "speed_scale",
        ):
            v = getattr(self, name)
            if not (isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v) and v > 0):
                problems.append(f"{name} must be a positive finite number, got {v!r}")
        for name in ("min_z", "padding", "range_rad"):
            v = getattr(self, name)
            if not (isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v)):
                problems.append(f"{name} must be a finite number, got {v!r}")
        if isinstance(self.padding, int | float) and self.padding < 0:
            problems.append(f"padding must be >= 0, got {self.padding}")
        if isinstance(self.range_rad, int | float) and self.range_rad < 0:
            problems.append(f"range_rad must be >= 0, got {self.range_rad}")
        if isinstance(self.speed_scale, int | float) and self.speed_scale > 1:
            problems.append(f"speed_scale must be <= 1, got {self.speed_scale}")
        step = self.check_step_deg
        if isinstance(step, int | float) and step > 10:
            problems.append(f"check_step_deg must be <= 10 (coarser checks tunnel through thin obstacles), got {step}")
        if isinstance(step, int | float) and 0 < step < MIN_CHECK_STEP_DEG:  # OMPL refuses a vanishing resolution
            problems.append(f"check_step_deg must be >= {MIN_CHECK_STEP_DEG} (a motion would take millions of checks)")
        if not (isinstance(self.seed, int) and not isinstance(self.seed, bool)):
            problems.append(f"seed must be an integer, got {self.seed!r}")
        if problems:
            raise ValueError("; ".join(problems))

    @property
    def anytime(self) -> bool:
        return PLANNERS[self.planner][1]

    @property
    def budget_s(self) -> float:
        """Planning time limit [s] of the chosen planner."""
        return self.anytime_budget_s if self.anytime else self.timeout_s

    def to_dict(self) -> dict:
        return asdict(self)

"""Configuration of the artificial potential field baseline (seed chapter 6 V-B, after Flacco et al. [38])."""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass


@dataclass
class PotentialFieldConfig:
    """Gains and budgets of `PotentialFieldPlanner`; velocities are integrated over steps of `dt`."""

    dt: float = 0.02
    """integration step [s]"""
    max_steps: int = 1500
    """step budget (at most max_steps * dt seconds of motion)"""
    attractive_gain: float = 3.0
    """TCP velocity per metre of position error [1/s]"""
    max_ee_speed: float = 0.3
    """cap of the attractive TCP velocity [m/s]"""
    repulsive_speed: float = 1.0
    """largest repulsive velocity of a control point [m/s], approached at zero clearance (0 = no repulsion)"""
    influence: float = 0.04
    """clearance [m] below which an obstacle repels a control point (rho in [38])"""
    shape: float = 6.0
    """steepness of the logistic repulsive profile (alpha in [38])"""
    self_influence: float = 0.05
    """clearance [m] below which two of the arm's spheres that may collide repel each other (0 = off)"""
    damping: float = 1e-3
    """damping of the least-squares pseudo-inverses [m^2]"""
    limit_gain: float = 1.0
    """joint-limit avoidance velocity at a limit, applied in the TCP Jacobian's null space [rad/s]"""
    limit_margin: float = 0.15
    """joints closer than this to a limit [rad] are pushed back"""
    joint_speed_scale: float = 0.5
    """the joint velocity is scaled down to at most this fraction of the limits V_MAX"""
    table: bool = True
    """the table plane z = 0 repels like an obstacle (and table collision stops the motion)"""
    check_collisions: bool = True
    """check every state exactly (self, table, obstacles); a colliding step ends planning"""
    stall_steps: int = 150
    """stop when the position error has not dropped by stall_progress over this many steps"""
    stall_progress: float = 0.005
    """progress [m] expected within stall_steps steps"""
    speed_scale: float = 0.5
    """fraction of the joint velocity limits used by the time parameterisation of the result"""

    def __post_init__(self) -> None:
        problems = []
        for name in (
            "dt",
            "attractive_gain",
            "max_ee_speed",
            "influence",
            "shape",
            "damping",
            "limit_margin",
            "joint_speed_scale",
            "stall_progress",
            "speed_scale",
        ):
            v = getattr(self, name)
            if not (isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v) and v > 0):
                problems.append(f"{name} must be a positive finite number, got {v!r}")
        for name in ("repulsive_speed", "limit_gain", "self_influence"):
            v = getattr(self, name)
            if not (isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v) and v >= 0):
                problems.append(f"{name} must be a finite number >= 0, got {v!r}")
        for name in ("max_steps", "stall_steps"):
            v = getattr(self, name)
            if not (isinstance(v, int) and not isinstance(v, bool) and v >= 1):
                problems.append(f"{name} must be an integer >= 1, got {v!r}")
        for name in ("joint_speed_scale", "speed_scale"):
            v = getattr(self, name)
            if isinstance(v, int | float) and v > 1:
                problems.append(f"{name} must be <= 1, got {v}")
        if problems:
            raise ValueError("; ".join(problems))

    def to_dict(self) -> dict:
        return asdict(self)

"""Scaled joint velocity, acceleration and jerk limits for trajectory generation."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from latent_planner_ros.robot.limits import A_MAX, J_MAX, V_MAX


@dataclass(frozen=True)
class MotionLimits:
    """Fractions of the Panda's datasheet limits (robot.limits V_MAX, A_MAX, J_MAX) a trajectory may use.

    Attributes:
        velocity_scale: fraction of V_MAX [rad/s], in (0, 1].
        acceleration_scale: fraction of A_MAX [rad/s^2], in (0, 1].
        jerk_scale: fraction of J_MAX [rad/s^3], in (0, 1].
    """

    velocity_scale: float = 0.5
    acceleration_scale: float = 0.3
    jerk_scale: float = 0.3

    def __post_init__(self):
        for name in ("velocity_scale", "acceleration_scale", "jerk_scale"):
            value = getattr(self, name)
            if not (isinstance(value, int | float) and 0 < value <= 1):
                raise ValueError(f"{name} must be in (0, 1], got {value!r}")

    @property
    def v_max(self) -> np.ndarray:
        """Velocity limits (7,) [rad/s]."""
        return self.velocity_scale * V_MAX

    @property
    def a_max(self) -> np.ndarray:
        """Acceleration limits (7,) [rad/s^2]."""
        return self.acceleration_scale * A_MAX

    @property
    def j_max(self) -> np.ndarray:
        """Jerk limits (7,) [rad/s^3]."""
        return self.jerk_scale * J_MAX


DEFAULT_LIMITS = MotionLimits()
"""Half the velocity limits, 0.3 of the acceleration and jerk limits."""

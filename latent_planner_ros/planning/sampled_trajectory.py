"""A joint trajectory sampled in time: what an execution interface (a JointTrajectoryController) is sent."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class SampledTrajectory:
    """Samples of a continuous joint trajectory.

    Attributes:
        times: (K,) time from start [s], strictly increasing, times[0] = 0.
        positions: (K, 7) [rad].
        velocities: (K, 7) [rad/s].
        accelerations: (K, 7) [rad/s^2].
        max_deviation_rad: largest Euclidean joint-space distance [rad] of the continuous trajectory (checked
            at least at the samples) from the piecewise-linear path it was made from.
    """

    times: np.ndarray
    positions: np.ndarray
    velocities: np.ndarray
    accelerations: np.ndarray
    max_deviation_rad: float = 0.0

    @property
    def duration(self) -> float:
        """Time [s] of the last sample."""
        return float(self.times[-1])

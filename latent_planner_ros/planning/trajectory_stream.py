"""Execute a time-parameterised joint trajectory by streaming position targets at a fixed period. No ROS.

Each tick advances the reference time by one period along the trajectory, unless the measured state lags
more than `lag_tol_rad` behind the last target (then the target is repeated, so the arm never cuts a corner
off the checked path). The target is also scaled towards the measured state so that no joint is asked to move
faster than its velocity limit over one period, and clamped into the joint limits.
"""

from __future__ import annotations

import numpy as np

from latent_planner_ros.robot.limits import Q_MAX, Q_MIN, V_MAX


class TrajectoryStreamer:
    """Targets along q_path (T, 7) [rad] at times (T,) [s], one per `period` [s].

    Args:
        q_path, times: the trajectory (times from 0, non-decreasing).
        period: command period [s] (0.1 at 10 Hz).
        lag_tol_rad: largest joint lag [rad] behind the last target for which the reference time advances.
        settle_ticks: after the end is commanded, ticks to wait for the arm to arrive before finishing.
        arrive_tol_rad: joint error [rad] at which the arm counts as arrived at the end.
    """

    def __init__(
        self,
        q_path: np.ndarray,
        times: np.ndarray,
        period: float = 0.1,
        lag_tol_rad: float = 0.05,
        settle_ticks: int = 20,
        arrive_tol_rad: float = 0.005,
    ):
        self.q_path = np.atleast_2d(np.asarray(q_path, dtype=float))
        self.times = np.asarray(times, dtype=float)
        if len(self.q_path) == 0 or self.times.shape != (len(self.q_path),):
            raise ValueError(f"q_path (T, 7) and times (T,) must match, got {self.q_path.shape}, {self.times.shape}")
        if not period > 0:
            raise ValueError(f"period must be positive, got {period}")
        self.period = period
        self.lag_tol_rad = lag_tol_rad
        self.settle_ticks = settle_ticks
        self.arrive_tol_rad = arrive_tol_rad
        self.t = 0.0
        self._target = self.q_path[0]
        self._ticks_at_end = 0
        self.done = False

    @property
    def duration(self) -> float:
        return float(self.times[-1])

    def reference(self, t: float) -> np.ndarray:
        """The trajectory (7,) [rad] at time t [s], linear between waypoints."""
        t = float(np.clip(t, 0.0, self.duration))
        k = int(np.clip(np.searchsorted(self.times, t, side="right") - 1, 0, len(self.times) - 1))
        if k == len(self.times) - 1:
            return self.q_path[-1].copy()
        dt = self.times[k + 1] - self.times[k]
        s = 0.0 if dt <= 0 else (t - self.times[k]) / dt
        return self.q_path[k] + s * (self.q_path[k + 1] - self.q_path[k])

    def next_command(self, q_measured: np.ndarray) -> np.ndarray | None:
        """The next target (7,) [rad] for the measured state q_measured (7,) [rad]; None once finished."""
        if self.done:
            return None
        q_measured = np.asarray(q_measured, dtype=float)
        if self.t >= self.duration:
            self._ticks_at_end += 1
            arrived = np.abs(q_measured - self.q_path[-1]).max() < self.arrive_tol_rad
            if arrived or self._ticks_at_end > self.settle_ticks:
                self.done = True
                return None
        elif np.abs(q_measured - self._target).max() <= self.lag_tol_rad:
            self.t = min(self.t + self.period, self.duration)
        self._target = self.reference(self.t)
        delta = self._target - q_measured
        limit = V_MAX * self.period
        scale = min(1.0, float(np.min(limit / np.maximum(np.abs(delta), 1e-12))))
        return np.clip(q_measured + scale * delta, Q_MIN, Q_MAX)

"""Time-parameterise a joint path so that no joint exceeds a fraction of its velocity limit."""

from __future__ import annotations

import numpy as np

from latent_planner_ros.robot.limits import V_MAX


def time_parameterise(q_path: np.ndarray, speed_scale: float = 0.5, min_dt: float = 1e-3) -> np.ndarray:
    """Times (T,) [s] for q_path (T, 7) [rad]: each segment lasts max_j |dq_j| / (speed_scale * V_MAX_j)."""
    if not 0 < speed_scale <= 1:
        raise ValueError(f"speed_scale must be in (0, 1], got {speed_scale}")
    q_path = np.atleast_2d(q_path)
    if len(q_path) == 0:
        return np.zeros(0)
    dq = np.abs(np.diff(q_path, axis=0))
    dt = np.maximum((dq / (speed_scale * V_MAX)).max(axis=1, initial=0.0), min_dt)
    return np.concatenate([[0.0], np.cumsum(dt)])


def interpolate(q_from: np.ndarray, q_to: np.ndarray, m: int) -> np.ndarray:
    """m states (m, 7) evenly spaced from q_from (excluded) to q_to (included)."""
    s = np.arange(1, m + 1, dtype=float)[:, None] / m
    return q_from[None] + s * (q_to - q_from)[None]

"""Closed-loop execution segments: short jerk-limited trajectories that replace each other. No ROS.

A JointTrajectoryController replaces its trajectory when a new one arrives and starts it from the state it is
commanding at that moment; a segment made here from that state (position, velocity, acceleration) to the
planner's next target therefore keeps the commanded velocity and acceleration continuous across replacements.
Each segment ends at rest on the target, so a planner that stops publishing leaves the arm holding there.
"""

from __future__ import annotations

import numpy as np

from latent_planner_ros.planning.motion_limits import DEFAULT_LIMITS, MotionLimits
from latent_planner_ros.planning.ruckig_segments import (
    polyline_deviation,
    ruckig_segment,
    sample_segments,
    sample_times,
)
from latent_planner_ros.planning.sampled_trajectory import SampledTrajectory


def segment_to_target(
    q: np.ndarray,
    dq: np.ndarray,
    ddq: np.ndarray,
    q_target: np.ndarray,
    limits: MotionLimits = DEFAULT_LIMITS,
    min_duration: float = 0.2,
    dt: float = 0.02,
) -> SampledTrajectory:
    """The time-optimal jerk-limited motion from the commanded state to q_target, at rest there.

    Args:
        q, dq, ddq: (7,) commanded position [rad], velocity [rad/s], acceleration [rad/s^2] now (the state of
            the trajectory being replaced at the new segment's start time; zeros when at rest).
        q_target: (7,) next target [rad].
        limits: velocity, acceleration and jerk limits (dq, ddq must be within them).
        min_duration: shortest segment [s]; about twice the planner period keeps the arm moving smoothly between
            targets instead of stopping at each one (a segment is replaced before it ends).
        dt: sample period [s].

    Returns:
        SampledTrajectory from t = 0 (the given state) to rest at q_target; max_deviation_rad is measured against
        the straight line q -> q_target.
    """
    states = [np.asarray(x, dtype=float) for x in (q, dq, ddq, q_target)]
    if any(x.shape != (7,) or not np.all(np.isfinite(x)) for x in states):
        raise ValueError(f"q, dq, ddq, q_target must be finite (7,) arrays, got {[x.shape for x in states]}")
    q, dq, ddq, q_target = states
    segment = ruckig_segment(q, dq, ddq, q_target, np.zeros(7), limits, min_duration=min_duration)
    times = sample_times(segment.duration, dt) if segment.duration > 0 else np.zeros(1)
    positions, velocities, accelerations = sample_segments([segment], times)
    velocities[-1] = 0.0
    accelerations[-1] = 0.0
    deviation = float(polyline_deviation(positions, np.stack([q, q_target])).max())
    return SampledTrajectory(times, positions, velocities, accelerations, deviation)

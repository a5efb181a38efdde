"""Closed-loop execution segments: short jerk-limited trajectories that replace each other. No ROS.

A JointTrajectoryController replaces its trajectory when a new one arrives and starts it from the state it is
commanding at that moment; a segment made here from that state (position, velocity, acceleration) to the
planner's next target therefore keeps the commanded velocity and acceleration continuous across replacements.
A segment ends at rest on the target, so a planner that stops publishing leaves the arm holding there; or, for a
closed loop that keeps moving (`v_target`), passes the target at that velocity and then stops within the
limits (a short run-on beyond the target, which the next segment replaces before it starts).
"""

from __future__ import annotations

import numpy as np

from latent_planner_ros.planning.motion_limits import DEFAULT_LIMITS, MotionLimits
from latent_planner_ros.planning.ruckig_segments import (
    polyline_deviation,
    ruckig_segment,
    ruckig_stop,
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
    v_target: np.ndarray | None = None,
) -> SampledTrajectory:
    """The time-optimal jerk-limited motion from the commanded state to q_target, at rest there (or, with
    v_target, through q_target at that velocity and on to rest).

    Args:
        q, dq, ddq: (7,) commanded position [rad], velocity [rad/s], acceleration [rad/s^2] now (the state of
            the trajectory being replaced at the new segment's start time; zeros when at rest).
        q_target: (7,) next target [rad].
        limits: velocity, acceleration and jerk limits (dq, ddq must be within them).
        min_duration: shortest segment [s]; about twice the planner period keeps the arm moving smoothly between
            targets instead of stopping at each one (a segment is replaced before it ends).
        dt: sample period [s].
        v_target: (7,) [rad/s] the velocity to pass q_target with (clipped to the limits), then a stop; None:
            at rest on q_target.

    Returns:
        SampledTrajectory from t = 0 (the given state) to rest at q_target; max_deviation_rad is measured against
        the straight line q -> q_target.
    """
    states = [np.asarray(x, dtype=float) for x in (q, dq, ddq, q_target)]
    if any(x.shape != (7,) or not np.all(np.isfinite(x)) for x in states):
        raise ValueError(f"q, dq, ddq, q_target must be finite (7,) arrays, got {[x.shape for x in states]}")
    q, dq, ddq, q_target = states
    through = (
        np.zeros(7) if v_target is None else np.clip(np.asarray(v_target, dtype=float), -limits.v_max, limits.v_max)
    )
    segments = [ruckig_segment(q, dq, ddq, q_target, through, limits, min_duration=min_duration)]
    if np.any(through != 0.0):
        segments.append(ruckig_stop(q_target, through, limits))
    duration = sum(s.duration for s in segments)
    times = sample_times(duration, dt) if duration > 0 else np.zeros(1)
    positions, velocities, accelerations = sample_segments(segments, times)
    velocities[-1] = 0.0
    accelerations[-1] = 0.0
    deviation = float(polyline_deviation(positions, np.stack([q, q_target])).max())
    return SampledTrajectory(times, positions, velocities, accelerations, deviation)

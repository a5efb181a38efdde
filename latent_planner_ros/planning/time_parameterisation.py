"""Time-parameterise a joint path: jerk-limited execution trajectories (ruckig) and velocity-scaled waypoint times.

Why ruckig: it is time-optimal, jerk-limited (a Franka arm trips its reflexes on acceleration steps, which
velocity/acceleration-only methods such as TOPP-RA produce) and starts from any state, so the same library makes
the one-shot trajectories here and the closed loop's replacing segments (planning.trajectory_segment).
Its community edition sends paths with intermediate waypoints to a cloud service, so a path is parameterised
segment by segment between its waypoints: each waypoint gets a velocity along the path's bisector direction
(zero at sharp turns, bounded by the limits and the adjacent segment lengths); a segment whose motion strays
more than `deviation_tol_rad` from the collision-checked piecewise-linear path has its end velocities halved
and, after `max_halvings`, set to zero: a segment at rest at both ends is the exact straight line
(ruckig_segments.LineMotion). The result therefore stays within `deviation_tol_rad` of the checked path.
"""

from __future__ import annotations

import numpy as np

from latent_planner_ros.planning.motion_limits import DEFAULT_LIMITS, MotionLimits
from latent_planner_ros.planning.ruckig_segments import (
    LineMotion,
    polyline_deviation,
    ruckig_segment,
    sample_segments,
    sample_times,
)
from latent_planner_ros.planning.sampled_trajectory import SampledTrajectory
from latent_planner_ros.robot.limits import V_MAX


def time_parameterise(q_path: np.ndarray, speed_scale: float = 0.5, min_dt: float = 1e-3) -> np.ndarray:
    """Times (T,) [s] for q_path (T, 7) [rad]: each segment lasts max_j |dq_j| / (speed_scale * V_MAX_j).

    Velocity-scaled waypoint times only (no acceleration or jerk limits); see jerk_limited_trajectory for execution.
    """
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


def jerk_limited_trajectory(
    q_path: np.ndarray,
    limits: MotionLimits = DEFAULT_LIMITS,
    dt: float = 0.01,
    deviation_tol_rad: float = 0.01,
    max_turn_rad: float = 1.0,
    max_halvings: int = 4,
) -> SampledTrajectory:
    """A trajectory through the waypoints q_path (T, 7) [rad], at rest at both ends, within `limits`.

    Args:
        q_path: (T, 7) joint path [rad], T >= 1; consecutive duplicates and collinear waypoints are merged.
        limits: velocity, acceleration and jerk limits.
        dt: sample period [s] of the result (the last sample is at the exact end time).
        deviation_tol_rad: largest allowed Euclidean joint-space distance [rad] from the polyline q_path.
        max_turn_rad: the path stops at waypoints where its direction turns by more than this angle [rad].
        max_halvings: halvings of a straying segment's end velocities before they are set to zero.

    Returns:
        SampledTrajectory: samples every dt [s] (K = ceil(duration / dt) + 1) with max_deviation_rad measured
        at the samples and at the checks of every segment.
    """
    if not dt > 0 or not deviation_tol_rad > 0:
        raise ValueError(f"dt and deviation_tol_rad must be positive, got {dt}, {deviation_tol_rad}")
    path = np.atleast_2d(np.asarray(q_path, dtype=float))
    if path.ndim != 2 or path.shape[1] != 7 or len(path) == 0 or not np.all(np.isfinite(path)):
        raise ValueError(f"q_path must be a finite (T, 7) array with T >= 1, got shape {path.shape}")
    waypoints = merge_collinear(path)
    if len(waypoints) == 1:
        zeros = np.zeros((1, 7))
        return SampledTrajectory(np.zeros(1), waypoints.copy(), zeros, zeros.copy())
    velocities = waypoint_velocities(waypoints, limits, max_turn_rad)
    halvings = np.zeros(len(waypoints), dtype=int)
    segments: list = [None] * (len(waypoints) - 1)
    dirty = set(range(len(segments)))
    deviation = 0.0
    while dirty:
        straying = set()
        for i in sorted(dirty):
            segments[i] = _segment(waypoints, velocities, i, limits)
            d = _segment_deviation(segments[i], waypoints, dt)
            if d > deviation_tol_rad:
                straying.add(i)
        dirty = set()
        for i in straying:
            for w in (i, i + 1):
                if not np.any(velocities[w]):
                    continue
                halvings[w] += 1
                velocities[w] = 0.5 * velocities[w] if halvings[w] <= max_halvings else 0.0
                dirty.update(k for k in (w - 1, w) if 0 <= k < len(segments))
    segments = _chained(waypoints, velocities, limits)
    times = sample_times(float(sum(s.duration for s in segments)), dt)
    positions, vel, acc = sample_segments(segments, times)
    deviation = max(
        float(polyline_deviation(positions, waypoints).max()),
        max(_segment_deviation(s, waypoints, dt) for s in segments),
    )
    positions[-1] = waypoints[-1]  # exactly on the goal (ruckig meets targets to ~1e-8 rad)
    vel[[0, -1]] = 0.0  # at rest at both ends (removes ~1e-16 residues)
    acc[[0, -1]] = 0.0
    return SampledTrajectory(times, positions, vel, acc, deviation)


def merge_collinear(path: np.ndarray, tol_rad: float = 1e-6) -> np.ndarray:
    """The waypoints (T', 7) of path (T, 7) [rad] without duplicates and without points on a straight run.

    A waypoint is dropped when it lies within tol_rad of the segment between the last kept waypoint and the
    next one, so the polyline changes by at most tol_rad.
    """
    kept = [path[0]]
    for i in range(1, len(path)):
        if np.linalg.norm(path[i] - kept[-1]) <= tol_rad:
            continue
        if i + 1 < len(path) and polyline_deviation(path[i], np.stack([kept[-1], path[i + 1]]))[0] <= tol_rad:
            continue
        kept.append(path[i])
    return np.stack(kept)


def waypoint_velocities(waypoints: np.ndarray, limits: MotionLimits, max_turn_rad: float) -> np.ndarray:
    """Velocities (T, 7) [rad/s] at waypoints (T, 7) [rad]: zero at the ends and at turns beyond max_turn_rad.

    Elsewhere along the bisector u of the adjacent segment directions, at the largest speed s with
    s * |u_j| <= v_max_j and s^2 * |u_j| <= a_max_j * L (L the shorter adjacent segment length [rad]),
    scaled by the cosine of the turn angle.
    """
    d = np.diff(waypoints, axis=0)
    lengths = np.linalg.norm(d, axis=1)
    e = d / lengths[:, None]
    velocities = np.zeros_like(waypoints)
    for i in range(1, len(waypoints) - 1):
        cos_turn = float(e[i - 1] @ e[i])
        if cos_turn < np.cos(max_turn_rad):
            continue
        u = e[i - 1] + e[i]
        u /= np.linalg.norm(u)
        au = np.maximum(np.abs(u), 1e-12)
        speed = min(np.min(limits.v_max / au), np.sqrt(np.min(limits.a_max * min(lengths[i - 1], lengths[i]) / au)))
        velocities[i] = cos_turn * speed * u
    return velocities


def _segment(waypoints: np.ndarray, velocities: np.ndarray, i: int, limits: MotionLimits):
    zero = np.zeros(7)
    if not (np.any(velocities[i]) or np.any(velocities[i + 1])):
        return LineMotion(waypoints[i], waypoints[i + 1], limits)
    return ruckig_segment(waypoints[i], velocities[i], zero, waypoints[i + 1], velocities[i + 1], limits)


def _chained(waypoints: np.ndarray, velocities: np.ndarray, limits: MotionLimits) -> list:
    """The segments recomputed in order, each from the state its predecessor reaches (ruckig meets a target to
    ~1e-8), so that position, velocity and acceleration are continuous to rounding at every join."""
    segments = []
    q, v, a = waypoints[0], np.zeros(7), np.zeros(7)
    for i in range(len(waypoints) - 1):
        if np.any(velocities[i]) or np.any(velocities[i + 1]):
            segment = ruckig_segment(q, v, a, waypoints[i + 1], velocities[i + 1], limits)
        else:
            segment = LineMotion(q, waypoints[i + 1], limits)
        segments.append(segment)
        q, v, a = (np.asarray(x) for x in segment.at_time(segment.duration))
    return segments


def _segment_deviation(segment, waypoints: np.ndarray, dt: float) -> float:
    """Largest distance [rad] from the polyline of a ruckig segment checked every min(dt, duration / 16) [s]."""
    times = np.linspace(0.0, segment.duration, max(17, int(np.ceil(segment.duration / dt)) + 1))
    positions = np.array([segment.at_time(float(t))[0] for t in times])
    return float(polyline_deviation(positions, waypoints).max())

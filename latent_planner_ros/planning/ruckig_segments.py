"""Jerk-limited joint motions between two states with ruckig, their sampling, and path deviation. No ROS.

Ruckig (Berscheid & Kröger, RSS 2021) computes the time-optimal motion from any current state (position,
velocity, acceleration) to a target state within velocity, acceleration and jerk limits, in microseconds, as
closed-form piecewise-cubic profiles. Its community edition computes single segments offline; intermediate
waypoints are sent to a cloud service, so paths are built here segment by segment (ruckig 0.19: `Ruckig.calculate`
with `InputParameter.intermediate_positions` calls api.ruckig.com).
"""

from __future__ import annotations

import numpy as np
from ruckig import ControlInterface, InputParameter, Result, Ruckig, Synchronization, Trajectory

from latent_planner_ros.planning.motion_limits import MotionLimits

DOF = 7


def ruckig_segment(
    q0: np.ndarray,
    v0: np.ndarray,
    a0: np.ndarray,
    q1: np.ndarray,
    v1: np.ndarray,
    limits: MotionLimits,
    min_duration: float = 0.0,
) -> Trajectory:
    """The time-optimal jerk-limited motion from (q0 [rad], v0 [rad/s], a0 [rad/s^2]) to (q1, v1, zero acceleration).

    All arrays (7,). Every joint finishes at the same time (phase synchronisation where ruckig finds one, else
    time synchronisation: the motion need not be straight; LineMotion is). min_duration [s] stretches a shorter
    motion. Raises RuntimeError when ruckig reports an error (e.g. a state beyond the limits).
    """
    inp = InputParameter(DOF)
    inp.current_position = np.asarray(q0, dtype=float).tolist()
    inp.current_velocity = np.asarray(v0, dtype=float).tolist()
    inp.current_acceleration = np.asarray(a0, dtype=float).tolist()
    inp.target_position = np.asarray(q1, dtype=float).tolist()
    inp.target_velocity = np.asarray(v1, dtype=float).tolist()
    inp.target_acceleration = [0.0] * DOF
    inp.max_velocity = limits.v_max.tolist()
    inp.max_acceleration = limits.a_max.tolist()
    inp.max_jerk = limits.j_max.tolist()
    inp.synchronization = Synchronization.Phase
    if min_duration > 0:
        inp.minimum_duration = float(min_duration)
    trajectory = Trajectory(DOF)
    result = Ruckig(DOF).calculate(inp, trajectory)
    if result not in (Result.Working, Result.Finished):
        raise RuntimeError(f"ruckig failed ({result}) from q0={inp.current_position} to q1={inp.target_position}")
    return trajectory


def ruckig_stop(q0: np.ndarray, v0: np.ndarray, limits: MotionLimits) -> Trajectory:
    """The time-optimal jerk-limited stop from (q0 [rad], v0 [rad/s], zero acceleration) (7,): velocity control
    to rest; the position runs on by about v0^2 / (2 a_max)."""
    inp = InputParameter(DOF)
    inp.control_interface = ControlInterface.Velocity
    inp.current_position = np.asarray(q0, dtype=float).tolist()
    inp.current_velocity = np.asarray(v0, dtype=float).tolist()
    inp.current_acceleration = [0.0] * DOF
    inp.target_velocity = [0.0] * DOF
    inp.target_acceleration = [0.0] * DOF
    inp.max_velocity = limits.v_max.tolist()
    inp.max_acceleration = limits.a_max.tolist()
    inp.max_jerk = limits.j_max.tolist()
    trajectory = Trajectory(DOF)
    result = Ruckig(DOF).calculate(inp, trajectory)
    if result not in (Result.Working, Result.Finished):
        raise RuntimeError(f"ruckig failed ({result}) stopping from v0={inp.current_velocity}")
    return trajectory


class LineMotion:
    """The time-optimal rest-to-rest motion along the straight line q0 -> q1 (7,) [rad] within `limits`.

    Ruckig's phase synchronisation keeps a 7-joint motion straight only when one joint limits velocity,
    acceleration and jerk alike; here ruckig moves the path parameter s in [0, 1] under the tightest joint
    limits divided by the joint displacements, so the motion is exactly straight. Same at_time/duration
    interface as a ruckig Trajectory.
    """

    def __init__(self, q0: np.ndarray, q1: np.ndarray, limits: MotionLimits):
        self.q0 = np.asarray(q0, dtype=float)
        self.delta = np.asarray(q1, dtype=float) - self.q0
        moving = np.abs(self.delta) > 1e-12
        inp = InputParameter(1)
        inp.current_position, inp.target_position = [0.0], [1.0 if moving.any() else 0.0]
        if moving.any():
            d = np.abs(self.delta[moving])
            inp.max_velocity = [float(np.min(limits.v_max[moving] / d))]
            inp.max_acceleration = [float(np.min(limits.a_max[moving] / d))]
            inp.max_jerk = [float(np.min(limits.j_max[moving] / d))]
        else:
            inp.max_velocity, inp.max_acceleration, inp.max_jerk = [1.0], [1.0], [1.0]
        self._s = Trajectory(1)
        result = Ruckig(1).calculate(inp, self._s)
        if result not in (Result.Working, Result.Finished):
            raise RuntimeError(f"ruckig failed ({result}) along the line {self.q0} -> {q1}")

    @property
    def duration(self) -> float:
        """Duration [s]."""
        return self._s.duration

    def at_time(self, t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Position (7,) [rad], velocity [rad/s], acceleration [rad/s^2] at time t [s] from the start."""
        s, ds, dds = (x[0] for x in self._s.at_time(t))
        return self.q0 + s * self.delta, ds * self.delta, dds * self.delta


def sample_times(duration: float, dt: float) -> np.ndarray:
    """Times (K,) [s] every dt [s] from 0, ending exactly at duration (K >= 2 for a positive duration)."""
    times = np.arange(0.0, duration, dt)
    if len(times) > 1 and duration - times[-1] < 0.5 * dt:
        times = times[:-1]  # no sliver before the end point
    return np.append(times, duration)


def sample_segments(
    segments: list[Trajectory | LineMotion], times: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Positions, velocities, accelerations (K, 7) of consecutive ruckig segments at times (K,) [s] from 0."""
    ends = np.cumsum([s.duration for s in segments])
    starts = ends - np.array([s.duration for s in segments])
    index = np.clip(np.searchsorted(ends, times, side="left"), 0, len(segments) - 1)
    out = np.empty((3, len(times), DOF))
    for k, (t, i) in enumerate(zip(times, index, strict=True)):
        segment = segments[i]
        out[:, k] = segment.at_time(float(np.clip(t - starts[i], 0.0, segment.duration)))
    return out[0], out[1], out[2]


def polyline_deviation(points: np.ndarray, path: np.ndarray, chunk: int = 512) -> np.ndarray:
    """Euclidean distance (S,) [rad] of each point (S, 7) to the nearest point of the polyline path (T, 7)."""
    points = np.atleast_2d(points)
    path = np.atleast_2d(path)
    if len(path) == 1:
        return np.linalg.norm(points - path[0], axis=1)
    a, ab = path[:-1], np.diff(path, axis=0)  # (T-1, 7)
    ab2 = np.maximum((ab * ab).sum(axis=1), 1e-300)
    out = np.empty(len(points))
    for i in range(0, len(points), chunk):
        ap = points[i : i + chunk, None, :] - a[None]  # (S, T-1, 7)
        s = np.clip((ap * ab[None]).sum(axis=2) / ab2[None], 0.0, 1.0)
        d = np.linalg.norm(ap - s[..., None] * ab[None], axis=2)
        out[i : i + chunk] = d.min(axis=1)
    return out

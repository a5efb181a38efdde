"""A JointTrajectoryController-like follower for the sim's PD control. No ROS.

Like ros2_controllers' JointTrajectoryController: a trajectory's times are relative to its start stamp (stamp 0 =
when it is received); it replaces the current one at that start time, from the state being commanded then (that
state is the first knot, so the command stays continuous); points already in the past at that time are dropped
and a trajectory that has ended before it starts is refused; a point less than MIN_BRIDGE_S after that time is
dropped too (the controller's interpolation from the commanded state needs a few steps). Between points it
interpolates the way a JTC does: linearly with positions only, cubic with velocities, quintic with accelerations
(scipy BPoly.from_derivatives).
After the last point it holds that position at zero velocity. Unlike a bare JTC it refuses a trajectory that
leaves the joint limits or exceeds the velocity or acceleration limits (its given values, or the mean velocity
between two points), with the joint and time: such a trajectory would trip a real arm's reflexes, and values
far beyond them made MuJoCo reset the simulation.
"""

from __future__ import annotations

import numpy as np
from scipy.interpolate import BPoly

from latent_planner_ros.robot.limits import A_MAX, JOINT_NAMES, Q_MAX, Q_MIN, V_MAX

POSITION_TOL_RAD = 0.05
"""how far [rad] a point may lie outside the joint limits (a segment's stopping tail near a limit)"""
RATE_TOL = 1.1
"""factor on the velocity and acceleration limits a trajectory may reach"""
MIN_BRIDGE_S = 0.02
"""[s] on replacing, the commanded state is joined to the first point at least this far ahead: a point a step
after the splice would ask the whole difference between the two trajectories then of one step (a jolt)"""
FUTURE_STAMP_S = 5.0
"""[s] a trajectory stamped farther ahead of the sim's clock is refused (a sender on the wall clock, not sim time)"""
INTERPOLATION_SAMPLES = 4
"""positions checked between each two points of a trajectory with velocities"""


class TrajectoryFollower:
    """Position and velocity targets (7,) [rad], [rad/s] at any sim time from the latest trajectory.

    Args:
        q0: (7,) [rad] position held until the first trajectory starts.
    """

    def __init__(self, q0: np.ndarray):
        self._last_time = -np.inf  # of the last sample [s]
        self.hold(q0)

    def hold(self, q: np.ndarray) -> None:
        """Drop the current and any queued trajectory and hold q (7,) [rad] at rest (e.g. when another command
        source hands the arm over)."""
        self._hold = np.asarray(q, dtype=float).copy()
        self._active: tuple[float, BPoly] | None = None  # (start time [s], the (7,)-valued spline)
        self._pending: tuple[float, np.ndarray, np.ndarray, np.ndarray | None, np.ndarray | None] | None = None

    def set_trajectory(
        self,
        times: np.ndarray,
        positions: np.ndarray,
        velocities: np.ndarray | None = None,
        accelerations: np.ndarray | None = None,
        stamp: float = 0.0,
        now: float = 0.0,
    ) -> str:
        """Queue a trajectory; returns '' when accepted, else why it was refused (the current one continues).

        Args:
            times: (K,) time from start [s], >= 0, strictly increasing.
            positions: (K, 7) [rad]; velocities (K, 7) [rad/s], accelerations (K, 7) [rad/s^2] or None.
            stamp: start time [s] in sim time; 0 means now.
            now: current sim time [s].
        """
        t = np.asarray(times, dtype=float)
        q = np.asarray(positions, dtype=float)
        if t.ndim != 1 or len(t) == 0 or q.shape != (len(t), 7):
            return f"expected times (K,) and positions (K, 7), got {t.shape}, {q.shape}"
        if t[0] < 0 or np.any(np.diff(t) <= 0) or not np.all(np.isfinite(t)) or not np.all(np.isfinite(q)):
            return "times must be finite, >= 0 and strictly increasing; positions finite"
        derivs = [None if d is None else np.asarray(d, dtype=float) for d in (velocities, accelerations)]
        if any(d is not None and (d.shape != q.shape or not np.all(np.isfinite(d))) for d in derivs):
            return f"velocities and accelerations must be finite ({len(t)}, 7) arrays"
        beyond = limit_violation(t, q, derivs[0], derivs[1])
        if beyond:
            return beyond
        start = now if stamp == 0 else float(stamp)
        if start - now > FUTURE_STAMP_S:
            return (
                f"trajectory stamped {start - now:.3g} s ahead of the sim's clock ({now:.3f} s): is the sender on "
                "another clock (use_sim_time)?"
            )
        if start + t[-1] < now:
            return f"trajectory ended {now - start - t[-1]:.3f} s ago"
        self._pending = (start, t, q, derivs[0], derivs[1])
        return ""

    def sample(self, time: float) -> tuple[np.ndarray, np.ndarray]:
        """Position (7,) [rad] and velocity (7,) [rad/s] targets at sim time [s] (non-decreasing between calls)."""
        if self._pending is not None and time >= self._pending[0]:
            self._activate(max(self._pending[0], self._last_time))
        self._last_time = time
        if self._active is None:
            return self._hold.copy(), np.zeros(7)
        spline = self._active[1]
        end = spline.x[-1]
        if time >= end:
            return spline(end), np.zeros(7)
        return spline(time), spline(time, 1)

    def _activate(self, time: float) -> None:
        start, t, q, dq, ddq = self._pending
        self._pending = None
        q_now, dq_now = self.sample(time)
        ddq_now = self.acceleration(time)
        keep = start + t > time + MIN_BRIDGE_S  # points still ahead, the first far enough to bridge to
        if not keep.any():
            keep[-1] = start + t[-1] > time
        abs_t = np.concatenate([[time], start + t[keep]])
        orders = [q_now[None], q[keep]]
        if dq is not None:
            orders = [np.stack([q_now, dq_now, ddq_now])[None] if ddq is not None else np.stack([q_now, dq_now])[None]]
            rows = [q[keep], dq[keep]] + ([ddq[keep]] if ddq is not None else [])
            knots = np.concatenate([orders[0], np.stack(rows, axis=1)])  # (K', n_derivatives, 7)
        else:
            knots = np.concatenate(orders)[:, None, :]
        if len(abs_t) == 1:  # the last point is exactly now
            abs_t, knots = np.array([time, time + 1e-9]), np.stack([knots[0], knots[0]])
        splines = [BPoly.from_derivatives(abs_t, knots[:, :, j]) for j in range(7)]
        spline = BPoly(np.stack([s.c for s in splines], axis=-1), abs_t)  # one (7,)-valued spline: one call a step
        self._active = (start, spline)
        self._hold = spline(abs_t[-1])

    def acceleration(self, time: float) -> np.ndarray:
        """Acceleration target (7,) [rad/s^2] of the active trajectory at sim time [s] (zero when holding)."""
        if self._active is None or time >= self._active[1].x[-1]:
            return np.zeros(7)
        return self._active[1](time, 2)

    def end_time(self) -> float:
        """Sim time [s] at which the latest accepted trajectory (queued or active) ends; -inf before any."""
        if self._pending is not None:
            return self._pending[0] + float(self._pending[1][-1])
        return float(self._active[1].x[-1]) if self._active is not None else -np.inf


def limit_violation(
    times: np.ndarray, q: np.ndarray, dq: np.ndarray | None = None, ddq: np.ndarray | None = None
) -> str:
    """'' when a trajectory keeps within the Panda's limits, else the first limit it breaks, naming joint and time.

    Args:
        times: (K,) [s], strictly increasing; q: (K, 7) [rad]; dq: (K, 7) [rad/s] or None; ddq: (K, 7) [rad/s^2]
        or None. Positions may lie POSITION_TOL_RAD outside the joint limits, rates reach RATE_TOL x the limits.
    """
    checks = [
        ("position", q, Q_MIN - POSITION_TOL_RAD, Q_MAX + POSITION_TOL_RAD, "rad", times),
        ("velocity", dq, -RATE_TOL * V_MAX, RATE_TOL * V_MAX, "rad/s", times),
        ("acceleration", ddq, -RATE_TOL * A_MAX, RATE_TOL * A_MAX, "rad/s^2", times),
    ]
    if len(times) > 1:  # the mean velocity between consecutive points, the positions between them
        mean = np.diff(q, axis=0) / np.diff(times)[:, None]
        checks.append(("mean velocity", mean, -RATE_TOL * V_MAX, RATE_TOL * V_MAX, "rad/s", times[1:]))
        if dq is not None:  # a cubic or quintic between points may swing out of the limits
            knots = np.stack([q, dq] + ([ddq] if ddq is not None else []), axis=1)  # (K, orders, 7)
            fractions = np.linspace(0.0, 1.0, INTERPOLATION_SAMPLES + 2)[1:-1]
            between = (times[:-1, None] + np.diff(times)[:, None] * fractions).ravel()
            swing = np.stack([BPoly.from_derivatives(times, knots[:, :, j])(between) for j in range(7)], axis=1)
            checks.append(
                ("interpolated position", swing, Q_MIN - POSITION_TOL_RAD, Q_MAX + POSITION_TOL_RAD, "rad", between)
            )
    for what, values, low, high, unit, at in checks:
        if values is None:
            continue
        bad = (values < low) | (values > high)
        if bad.any():
            k, j = np.argwhere(bad)[0]
            limit = high[j] if values[k, j] > high[j] else low[j]
            return (
                f"{what} of {JOINT_NAMES[j]} at t={at[k]:.4g} s is {values[k, j]:.4g} {unit}, beyond its limit "
                f"{limit:.4g} {unit}: trajectory refused"
            )
    return ""

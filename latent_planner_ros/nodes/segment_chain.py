"""The closed loop's execution segments, each starting from the state of the one it replaces. No ROS.

At every tick the planner sends a short jerk-limited segment to its next target (planning.trajectory_segment)
on ``joint_trajectory``; a JointTrajectoryController replaces the running segment with it from the state it
commands then. The chain starts each segment from the previous segment's state at that time (position, velocity,
acceleration, interpolated between its samples), so the commanded velocity stays continuous. Once the previous
segment has ended the controller holds its end, which the arm reaches a little later (its tracking lag): a segment
made then (a late tick) starts at rest from that held end while the measured state lies within REJOIN_RAD of it, so
the controller's command does not jump back to where the arm lags (that jump measured 12-20 rad/s^2 on joint 2
through the node, against the 5.6 the tests allow); farther (the arm was moved: a reset, another command source),
or before the first segment, it starts at rest from the measured joint state.
"""

from __future__ import annotations

import numpy as np

from latent_planner_ros.planning.motion_limits import MotionLimits
from latent_planner_ros.planning.sampled_trajectory import SampledTrajectory
from latent_planner_ros.planning.trajectory_segment import segment_to_target

SEGMENT_LEAD_S = 0.04
"""[s] a segment starts this long after it is sent (its stamp): most arrive before their start through the node on
this project's machines, and the controller then switches at that instant, seamlessly"""
REJOIN_RAD = 0.05
"""[rad] after the last segment ended, the next starts from its end while every measured joint is this close to it"""


def state_at(trajectory: SampledTrajectory, t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Position [rad], velocity [rad/s], acceleration [rad/s^2] (7,) each at t [s] from the trajectory's start,
    interpolated linearly between samples; after the end: the last position at rest."""
    if t >= trajectory.duration:
        return trajectory.positions[-1].copy(), np.zeros(7), np.zeros(7)
    t = max(float(t), 0.0)
    return tuple(
        np.array([np.interp(t, trajectory.times, x[:, j]) for j in range(7)])
        for x in (trajectory.positions, trajectory.velocities, trajectory.accelerations)
    )


class SegmentChain:
    """Segments that replace each other at the planner's rate.

    Args:
        dt: sample period [s] of the segments.
    """

    def __init__(self, dt: float = 0.02):
        self.dt = float(dt)
        self.last: tuple[float, SampledTrajectory] | None = None
        """(start time [s], segment) of the last segment made"""
        self._target: tuple[float, np.ndarray] | None = None  # (time [s], q_target (7,)) of the last segment

    def reset(self) -> None:
        """Forget the last segment (the next one starts at rest from the measured state)."""
        self.last = None
        self._target = None

    def next(
        self, now: float, q_target: np.ndarray, q_measured: np.ndarray, limits: MotionLimits, period_s: float
    ) -> SampledTrajectory:
        """The segment that starts at `now` [s] and ends at rest on q_target (7,) [rad].

        Args:
            q_measured: (7,) [rad] the arm's joint state, the start when no segment ran or the arm is not near the
                last one's end (REJOIN_RAD).
            limits: velocity, acceleration and jerk limits of the segment.
            period_s: [s] the planner's period; a segment lasts at least two (it is replaced before it ends).
        """
        if self.last is not None and now - self.last[0] < self.last[1].duration:
            q, dq, ddq = state_at(self.last[1], now - self.last[0])
            dq, ddq = np.clip(dq, -limits.v_max, limits.v_max), np.clip(ddq, -limits.a_max, limits.a_max)
        elif self.last is not None and np.abs(self.last[1].positions[-1] - q_measured).max() <= REJOIN_RAD:
            q, dq, ddq = self.last[1].positions[-1].copy(), np.zeros(7), np.zeros(7)  # the end the controller holds
        else:
            q, dq, ddq = np.asarray(q_measured, dtype=float), np.zeros(7), np.zeros(7)
        # keep moving as the targets move: pass this target at the targets' velocity, reached in one period
        v_target = None
        if self._target is not None and 0.0 < now - self._target[0] <= 2.0 * period_s:
            v_target = (np.asarray(q_target, dtype=float) - self._target[1]) / (now - self._target[0])
        min_duration = period_s if v_target is not None else 2.0 * period_s
        segment = segment_to_target(
            q, dq, ddq, q_target, limits, min_duration=min_duration, dt=self.dt, v_target=v_target
        )
        self.last = (now, segment)
        self._target = (now, np.asarray(q_target, dtype=float).copy())
        return segment

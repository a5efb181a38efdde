"""Background plans for the closed loop, and the following of their paths. ROS-free.

A still goal is planned once in the background by the open-loop planner (all its seeds, restarts and escapes);
while the plan runs the loop holds for up to `plan_wait_s`, then steps locally. When the plan arrives for the
goal still being chased, its path is streamed at the control rate (TrajectoryStreamer: velocity-limited targets
that wait for a lagging arm). The closed loop hard-checks every streamed command against the newest scene; a
blocked command, a goal that moved by more than `follow_goal_tol_m` or a finished path hands back to local steps.
Without a path to follow, local steps that make no progress for `replan_after_s` ask for a new plan (new seeds).

Leaving a grasp: the approach (the straight end) of the last followed grasp plan is kept. When a new goal arrives
with the arm on that approach (at or near the grasp), the arm first retreats back along it to the pre-grasp state
(`retreat`), checked against the cloud without the left grasp's target (`leaving`), as the approach was; only then
is the new goal planned, from outside the object. A plan from the grasp pose itself starts inside the target
(an obstacle again) and may sweep through it.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from latent_planner_ros.planning.goal import Goal
from latent_planner_ros.planning.plan_runner import PlanOutcome, PlanRequest
from latent_planner_ros.planning.time_parameterisation import time_parameterise
from latent_planner_ros.planning.trajectory_stream import TrajectoryStreamer

STILL_GOAL_MPS = 0.02
"""[m/s] a goal moving slower than this is still: it is worth a background plan"""

ON_APPROACH_RAD = 0.05
"""[rad] the arm is on a grasp's approach when some state of it is within this of the measured state (every joint)"""


class PlanFollower:
    """Requests background plans through `runner` (ThreadedPlanRunner or DeferredPlanRunner) and streams their
    paths at `period` [s].

    Args:
        runner: submit(PlanRequest, now), poll(now) -> PlanOutcome | None, busy.
        period: control period [s].
        follow_goal_tol_m: a path is followed only while the goal is within this [m] of the goal it was planned for.
        replan_after_s: local steps without progress for this long [s] ask for a new plan.
        plan_wait_s: the loop holds this long [s] for the plan of a new goal before it steps locally.
    """

    def __init__(self, runner: Any, period: float, follow_goal_tol_m: float, replan_after_s: float, plan_wait_s: float):
        self.runner = runner
        self.period = period
        self.follow_goal_tol_m = follow_goal_tol_m
        self.replan_after_s = replan_after_s
        self.plan_wait_s = plan_wait_s
        self._ident = 0
        self._requested: np.ndarray | None = None  # goal position (3,) [m] of the newest request
        self._requested_at = -np.inf  # [s]
        self._requested_grasp = None  # the GraspSpec of the newest request (None: a reach goal)
        self._answered = True  # the newest request has its outcome
        self._retry = False  # the newest request re-plans a goal planned before
        self._stream: TrajectoryStreamer | None = None
        self._plan_goal: np.ndarray | None = None  # goal position (3,) [m] the followed path was planned for
        self.escape_from: np.ndarray | None = None  # the followed path's start (7,) [rad] when the check refused it
        self.note = "no plan"  # for the status: what the background planner did last
        self.plans = {"requested": 0, "followed": 0, "failed": 0, "dropped": 0, "retreats": 0}
        # the approach (K, 7) [rad] of the last followed grasp plan (pre-grasp state first), its GraspSpec and goal
        self.approach: tuple[np.ndarray, Any, Goal] | None = None
        self._retreat: TrajectoryStreamer | None = None
        self._retreat_of: tuple[np.ndarray, Any, Goal] | None = None  # the approach being retreated along
        self.retreat_ended = False  # set when a retreat ends (done or dropped); the caller clears it

    @property
    def leaving(self) -> tuple[Any, Goal] | None:
        """(GraspSpec, goal) of the grasp the arm is retreating from, or None: while set, the target's points stay
        out of the cloud the commands are checked against."""
        return None if self._retreat_of is None else (self._retreat_of[1], self._retreat_of[2])

    @property
    def retreating(self) -> bool:
        return self._retreat is not None

    def retreat(self, q: np.ndarray, speed_scale: float) -> bool:
        """Start a retreat along the kept approach when the measured q (7,) [rad] is on it (ON_APPROACH_RAD) and past
        its first (pre-grasp) state; returns whether it started. The kept approach is used up either way."""
        approach, self.approach = self.approach, None
        if approach is None:
            return False
        path = approach[0]
        dev = np.abs(path - q).max(axis=1)
        k = int(np.argmin(dev))
        if dev[k] > ON_APPROACH_RAD or k == 0:
            return False
        back = np.concatenate([np.asarray(q, dtype=float)[None], path[k::-1]])
        self._retreat = TrajectoryStreamer(back, time_parameterise(back, speed_scale), period=self.period)
        self._retreat_of = approach
        self._stream, self._plan_goal, self.escape_from = None, None, None
        self.plans["retreats"] += 1
        self.note = f"retreating along the approach of the grasp left ({k} of {len(path) - 1} states)"
        return True

    def _end_retreat(self, note: str) -> None:
        if self._retreat is not None:
            self._retreat, self._retreat_of, self.retreat_ended = None, None, True
            self.note = note

    @property
    def following(self) -> bool:
        return self._stream is not None

    @property
    def waypoint(self) -> str:
        """The followed path's progress, e.g. "1.2/3.4 s"."""
        s = self._stream
        return "" if s is None else f"{s.t:.1f}/{s.duration:.1f} s"

    def waiting(self, now: float) -> bool:
        """The plan of a new goal was requested less than plan_wait_s ago and has not arrived: hold. (While a
        re-plan runs the loop steps locally, and its no-progress watchdog keeps counting.)"""
        return not self._answered and not self._retry and now - self._requested_at < self.plan_wait_s

    def forget(self) -> None:
        """Drop the path and forget the requests (a cleared goal, a disabled loop): outcomes still running are
        ignored when they arrive."""
        self._stream, self._plan_goal, self._requested, self._requested_grasp = None, None, None, None
        self._ident += 1
        self._answered = True
        if self._retreat is not None:  # the approach is kept: a new goal resumes the retreat from where the arm is
            self.approach = self._retreat_of
            self._end_retreat("retreat interrupted")

    def drop(self, reason: str) -> None:
        """Stop following the path or the retreat (the loop goes on with local steps)."""
        if self._retreat is not None:
            self._end_retreat(f"retreat dropped: {reason}")
        if self._stream is not None:
            self.plans["dropped"] += 1
            self.note = f"plan dropped: {reason}"
        self._stream, self._plan_goal = None, None

    def update(
        self,
        now: float,
        q: np.ndarray,
        goal: Goal,
        goal_speed: float,
        stalled_s: float,
        scene,
        cloud,
        grasp=None,
        views: int = 1,
        eyes: np.ndarray | None = None,
    ):
        """Take up a finished plan and request a new one when it is worth it; once per tick.

        Args:
            now: time [s]; q: measured state (7,) [rad]; goal: the goal to plan for; goal_speed: its speed [m/s];
            stalled_s: time [s] since the loop last made progress; scene, cloud, grasp, views, eyes: as in
            PlanRequest.
        """
        outcome = self.runner.poll(now)
        if outcome is not None:
            self._take(outcome, goal)
        if self._retreat is not None:  # the new goal is planned from where the retreat ends
            return
        if goal_speed > STILL_GOAL_MPS or self.runner.busy or self._stream is not None:
            return
        new_goal = self._requested is None or np.linalg.norm(goal.position - self._requested) > self.follow_goal_tol_m
        new_goal = new_goal or grasp != self._requested_grasp
        retry = now - self._requested_at > self.replan_after_s and stalled_s > self.replan_after_s
        if new_goal or retry:
            self._retry = not new_goal
            self._ident += 1
            self._requested, self._requested_at, self._answered = goal.position.copy(), now, False
            self._requested_grasp = grasp
            self.plans["requested"] += 1
            self.runner.submit(PlanRequest(q.copy(), goal, scene, cloud, self._ident, grasp, views, eyes), now)

    def _take(self, outcome: PlanOutcome, goal: Goal) -> None:
        if outcome.request.ident != self._ident:
            return  # superseded
        self._answered = True
        result, planned = outcome.result, outcome.request.goal.position
        if result is None or not result.success:
            self.plans["failed"] += 1
            why = outcome.error if result is None else result.reason
            self.note = f"background plan failed ({why}); local steps"
            return
        if np.linalg.norm(goal.position - planned) > self.follow_goal_tol_m:
            self.note = "background plan arrived for a goal that has since moved; local steps"
            return
        self._stream = TrajectoryStreamer(result.q_path, result.times, period=self.period)
        n = int(result.info.get("approach_states", 0)) if outcome.request.grasp is not None else 0
        if n > 0 and n < len(result.q_path):  # the pre-grasp state and the approach after it
            self.approach = (result.q_path[-n - 1 :].copy(), outcome.request.grasp, outcome.request.goal)
        self.escape_from = result.q_path[0].copy() if result.info.get("start_refused") else None
        self._plan_goal = np.asarray(planned, dtype=float).copy()
        self.plans["followed"] += 1
        self.note = f"following a plan found in {outcome.wall_s:.2f} s ({len(result.q_path)} waypoints)"

    def command(self, q: np.ndarray, goal: Goal) -> np.ndarray | None:
        """The next target (7,) [rad] along the followed path (not yet hard-checked against the newest scene), or
        None when there is none (no path, the goal moved off it, or the path is done). A retreat comes first."""
        if self._retreat is not None:
            target = self._retreat.next_command(q)
            if target is not None:
                return target
            self._end_retreat("retreated along the approach of the grasp left")
            return None
        if self._stream is None:
            return None
        if np.linalg.norm(goal.position - self._plan_goal) > self.follow_goal_tol_m:
            self.drop("the goal moved")
            return None
        target = self._stream.next_command(q)
        if target is None:
            self._stream, self._plan_goal = None, None
            self.note = "plan followed to its end"
        return target

"""Closed-loop supervision around AMP-LS: fresh inputs or hold, goal checks, progress watchdog.

ROS-free: the planner node feeds it converted messages with receipt times and publishes what `tick`
returns. A tick either commands the next joint target or holds (commands the measured position) or, with
stale joint states, commands nothing; every outcome carries a reason for the status topic.
"""

from __future__ import annotations

import time
from collections import deque
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from latent_planner_ros.params.config import MIN_RATE_HZ
from latent_planner_ros.planning.amp_ls import AmpLs
from latent_planner_ros.planning.evasion import Evader
from latent_planner_ros.planning.goal import Goal
from latent_planner_ros.planning.goal_visibility import goal_view
from latent_planner_ros.planning.grasp import GraspSpec
from latent_planner_ros.planning.ik import IkConfig, solve_ik
from latent_planner_ros.planning.plan_follow import STILL_GOAL_MPS, PlanFollower
from latent_planner_ros.robot.limits import JOINT_NAMES, Q_MAX, Q_MIN, V_MAX

OK, WARN, ERROR = 0, 1, 2

GOAL_VELOCITY_WINDOW_S = 0.3
"""[s] a moving goal's velocity is estimated from the goals received over this long (see goal_lead_s)"""
GOAL_JUMP_M = 0.05
"""[m] a goal farther than this from the previous one is a new goal (watchdog and velocity estimate restart)"""

SERVO_IK = IkConfig(max_iters=15, stall_iters=5, max_step_rad=0.2)
"""the IK servo's damped-least-squares iterations from the measured state (ClosedLoopConfig.servo_radius_m)"""

MEASURED_LIMIT_TOL_RAD = 0.05
"""[rad] a measured joint may lie this far outside its limits (compliance, calibration); farther is a faulty
measurement, refused like a malformed one (holds are commanded inside the limits either way)"""


@dataclass
class ClosedLoopConfig:
    rate_hz: float = 10.0
    """control rate [Hz]"""
    stale_joint_states_s: float = 0.5
    """joint states older than this [s] stop all commands"""
    stale_scene_s: float = 1.0
    """a scene older than this [s] makes the arm hold"""
    max_iterations_per_tick: int = 3
    """optimisation steps per tick at most"""
    accepted_steps_per_tick: int = 2
    """the tick ends once this many of its steps were accepted (more: a moving goal is caught up faster, within
    max_iterations_per_tick and tick_budget_ms)"""
    tick_budget_ms: float = 20.0
    """no further optimisation step starts in a tick once the time used plus the last step's time would exceed
    this [ms] (bounds the tick time; at least one step always runs)"""
    no_progress_s: float = 8.0
    """a goal whose error has not improved by progress_m within this time [s] is given up"""
    progress_m: float = 0.005
    """improvement [m] that counts as progress"""
    reach_m: float = 1.05
    """goals farther than this from the base axis origin [m] are refused as out of reach"""
    goal_clearance_m: float = 0.01
    """goals with an observed point closer than this [m] are refused as inside an obstacle"""
    goal_hidden_m: float = 0.08
    """[m] a goal that a camera sees hidden this close behind an observed surface (on its line of sight), and
    that no camera sees past, is refused as probably inside an object (planning/goal_visibility.py; needs the
    cameras' origins; 0 = off)"""
    goal_lead_s: float = 0.3
    """[s] chase where a moving goal will be this far ahead: its position plus its velocity (estimated over the
    goals of the last GOAL_VELOCITY_WINDOW_S) times this, to make up for the lag of commands and arm; 0 = the
    goal as received (a still goal is chased as it is either way)"""
    goal_lead_max_m: float = 0.1
    """[m] longest lead (a cap on velocity x goal_lead_s)"""
    evade_margin_m: float = 0.05
    """[m] when the arm's least sphere clearance to the observed cloud is below this, the cloud approaches the
    arm faster than evade_approach_mps and the tick's command would not gain clearance (a hold: no step accepted,
    no goal or a failure, with a cloud at most stale_scene_s old; or a step that gains less clearance than the
    cloud's approach takes in a control period), the arm retreats from the nearest points instead
    (planning/evasion.py); 0 = never"""
    evade_approach_mps: float = 0.02
    """[m/s] approach speed of the observed cloud (its clearance to the held arm, over about 0.3 s) that counts
    as an obstacle moving towards the arm"""
    follow_plans: bool = True
    """plan each still goal in the background with the open-loop planner (all its seeds and restarts) and follow
    its path, hard-checking every command against the newest scene; local steps while a plan is missing, blocked
    or the goal moves (planning/plan_follow.py). False: local steps only. Needs a plan runner (the node has one)"""
    plan_wait_s: float = 1.0
    """[s] the arm holds this long for the background plan of a new goal before it steps locally"""
    replan_after_s: float = 2.0
    """[s] without a path to follow, local steps without progress for this long ask for a new background plan"""
    follow_goal_tol_m: float = 0.02
    """[m] a path is followed only while the goal is within this of the goal it was planned for"""
    servo_radius_m: float = 0.4
    """[m] with the arm's TCP within this of a moving goal (led by goal_lead_s), a tick servos by IK instead of a
    latent step: a few damped-least-squares iterations from the measured state to the led goal, commanded when the
    straight segment to it passes the hard check and changes no joint by more than servo_max_rad (else the latent
    step as usual); the latent optimisation trails a fast goal by several ticks, IK does not. 0 = off (beyond the
    seed; on the fast conveyor, 30 trials to 15 cm/s: 28/30 at 0.4 m, 24/30 at 0.1 m, 17/30 without: far from
    a fast goal the latent steps only keep pace with it, docs/benchmark.md)"""
    servo_max_rad: float = 0.5
    """[rad] the largest joint change an IK servo target may ask for (a larger one is a different IK branch)"""
    servo_clearance_m: float = 0.05
    """[m] an IK servo command must keep the arm's spheres at least this far from the newest observed cloud, and
    twice this from a cloud approaching the arm at evade_approach_mps or faster (the servo goes straight for the
    goal, without the latent cost's margin: near obstacles, which may be moving and seen a camera period ago, the
    latent steps decide)"""

    def __post_init__(self) -> None:
        positive = ("rate_hz", "stale_joint_states_s", "stale_scene_s", "no_progress_s", "progress_m", "reach_m")
        for name in (*positive, "tick_budget_ms"):
            v = getattr(self, name)
            if not (isinstance(v, int | float) and not isinstance(v, bool) and np.isfinite(v) and v > 0):
                raise ValueError(f"{name} must be a positive finite number, got {v!r}")
        if self.rate_hz < MIN_RATE_HZ:  # its timer's period must be a finite count of nanoseconds
            raise ValueError(f"rate_hz must be at least {MIN_RATE_HZ} Hz, got {self.rate_hz!r}")
        for name in ("max_iterations_per_tick", "accepted_steps_per_tick"):
            v = getattr(self, name)
            if not (isinstance(v, int) and not isinstance(v, bool) and 1 <= v <= 100):
                raise ValueError(f"{name} must be an integer in [1, 100], got {v!r}")
        if not isinstance(self.follow_plans, bool):
            raise ValueError(f"follow_plans must be true or false, got {self.follow_plans!r}")
        for name in ("replan_after_s", "follow_goal_tol_m"):
            v = getattr(self, name)
            if not (isinstance(v, int | float) and not isinstance(v, bool) and np.isfinite(v) and v > 0):
                raise ValueError(f"{name} must be a positive finite number, got {v!r}")
        names = ("goal_clearance_m", "goal_hidden_m", "goal_lead_s", "goal_lead_max_m", "evade_margin_m",
                 "evade_approach_mps", "servo_radius_m", "servo_max_rad", "servo_clearance_m")  # fmt: skip
        for name in (*names, "plan_wait_s"):
            v = getattr(self, name)
            if not (isinstance(v, int | float) and not isinstance(v, bool) and np.isfinite(v) and v >= 0):
                raise ValueError(f"{name} must be a finite number >= 0, got {v!r}")


@dataclass
class TickOutcome:
    """What one control tick decided.

    Attributes:
        command: (7,) joint target to publish [rad], or None to publish nothing.
        state: "tracking", "reached", "evading", "holding", "failed", "disabled".
        reason: human-readable explanation.
        level: OK, WARN or ERROR (diagnostic level).
        values: figures for the status topic.
    """

    command: np.ndarray | None
    state: str
    reason: str
    level: int = OK
    values: dict[str, Any] = field(default_factory=dict)


class ClosedLoopController:
    """Feeds AMP-LS with the latest inputs at every tick; times are seconds on one clock.

    Args:
        planner: the planner whose `step` makes the local steps (and whose backend checks every command).
        config: rates, budgets and watchdogs.
        runner: runs background plans (planning/plan_runner.py) on a planner instance of its own; None (or
            config.follow_plans false) = local steps only.
    """

    def __init__(self, planner: AmpLs, config: ClosedLoopConfig | None = None, runner: Any = None):
        self.planner = planner
        self.config = config or ClosedLoopConfig()
        cfg = self.config
        self.follower = (
            PlanFollower(runner, 1.0 / cfg.rate_hz, cfg.follow_goal_tol_m, cfg.replan_after_s, cfg.plan_wait_s)
            if runner is not None and cfg.follow_plans
            else None
        )
        self.enabled = True
        self.goal: Goal | None = None
        self.grasp: GraspSpec | None = None  # set when the goal is a grasp (see set_goal)
        self.grasp_note = ""  # for the status: the target split of the newest cloud at a grasp goal
        self._raw_cloud: np.ndarray | None = None  # the newest cloud as received (the target not set aside)
        self.cloud_views = 1  # the cameras it was fused from
        self._q: np.ndarray | None = None
        self._q_time = -np.inf
        self._scene: Any = None
        self._scene_time = -np.inf
        self._cloud: np.ndarray | None = None
        self._eyes: np.ndarray | None = None  # optical centres (K, 3) [m] of the cameras of the cloud, if known
        self._failed: str | None = None
        self._best_err = np.inf
        self._best_time = 0.0
        self._best_goal: np.ndarray | None = None
        self._goal_track: deque[tuple[float, np.ndarray]] = deque()  # (time [s], position (3,) [m]) of goals
        self._checked_scene: Any = None  # the scene last handed to the backend for a followed command
        self._scene_after: float | None = None  # after a retreat: hold for a scene received after this time [s]
        checker = getattr(planner, "checker", None)
        # the newest clouds, for evasion (evade_margin_m) and the servo's clearance (servo_radius_m)
        watched = self.config.evade_margin_m > 0 or self.config.servo_radius_m > 0
        self._evader = Evader(self.config.evade_margin_m, checker=checker) if watched else None

    # -- inputs ----------------------------------------------------------------------------------
    def set_joint_state(self, q: np.ndarray, now: float) -> tuple[bool, str]:
        """The measured q (7,) [rad] at time now; returns (accepted, reason): a q farther than
        MEASURED_LIMIT_TOL_RAD outside the joint limits is refused (the last accepted one ages and goes stale)."""
        q = np.asarray(q, dtype=float)
        outside = (q < Q_MIN - MEASURED_LIMIT_TOL_RAD) | (q > Q_MAX + MEASURED_LIMIT_TOL_RAD)
        if np.any(outside):
            joints = ", ".join(f"{JOINT_NAMES[i]} = {q[i]:.3f} rad" for i in np.flatnonzero(outside))
            return False, f"measured state outside the joint limits: {joints}"
        self._q, self._q_time = q, now
        return True, ""

    def set_scene(
        self, scene: Any, now: float, cloud: np.ndarray | None = None, eyes: np.ndarray | None = None
    ) -> None:
        """The scene as the planner's collision backend consumes it, and the raw cloud if known (seen from the
        cameras at `eyes`, see set_cloud)."""
        self._scene, self._scene_time = scene, now
        if cloud is not None:
            self.set_cloud(cloud, now, eyes=eyes)

    @property
    def cloud_eyes(self) -> np.ndarray | None:
        """The optical centres (K, 3) [m] of the cameras of the latest cloud, if known."""
        return self._eyes

    def set_cloud(
        self, cloud: np.ndarray, now: float | None = None, views: int = 1, eyes: np.ndarray | None = None
    ) -> np.ndarray:
        """The latest raw cloud (N, 3) [m] (finite points), fused from `views` cameras, used to refuse goals inside
        observed obstacles and, with its time now [s], to notice obstacles approaching the arm (evade_margin_m);
        `views` goes with the background plans (the learned backend's network plans from one camera only);
        `eyes` (K, 3) [m], the optical centres of those cameras if known, let goals hidden behind observed
        surfaces be refused (goal_hidden_m).
        Returns the obstacles (M, 3) [m]: the cloud, or at a grasp goal the cloud without the target's points, which
        is what the hard check of every command must be given (the caller hands it to the backend)."""
        self._raw_cloud = np.asarray(cloud, dtype=float).reshape(-1, 3)
        self.cloud_views = max(1, int(views))
        self._eyes = None if eyes is None else np.asarray(eyes, dtype=float).reshape(-1, 3)
        self._cloud = self._obstacles(self._raw_cloud)
        if now is not None and self._evader is not None:
            self._evader.add_cloud(self._cloud, now)
        return self._cloud

    def _obstacles(self, cloud: np.ndarray) -> np.ndarray:
        """cloud (N, 3) [m] without the grasp target's points (the cloud itself at a reach goal; while retreating
        from a grasp, without that grasp's target)."""
        leaving = self.follower.leaving if self.follower is not None else None
        if leaving is not None:
            cloud = np.asarray(leaving[0].split(cloud, leaving[1]).obstacles, dtype=float)
        if self.grasp is None or self.goal is None:
            self.grasp_note = ""
            return cloud
        split = self.grasp.split(cloud, self.goal)
        self.grasp_note = split.report
        return np.asarray(split.obstacles, dtype=float)

    def check_goal(self, goal: Goal, check_cloud: bool = True) -> tuple[bool, str]:
        """(False, reason) for a goal out of reach or (check_cloud) inside an observed obstacle or hidden just
        behind an observed surface, else (True, "")."""
        dist = float(np.linalg.norm(goal.position - np.array([0.0, 0.0, 0.333])))
        if dist > self.config.reach_m:
            return (
                False,
                f"goal refused: {dist:.2f} m from the shoulder, beyond the reach of {self.config.reach_m:.2f} m",
            )
        if check_cloud and self._cloud is not None and len(self._cloud):
            d = float(np.min(np.linalg.norm(self._cloud - goal.position, axis=1)))
            if d < self.config.goal_clearance_m:
                return False, f"goal refused: inside an observed obstacle (a point {d * 1000:.0f} mm away)"
            if self.config.goal_hidden_m > 0 and self._eyes is not None:
                view = goal_view(goal.position, self._cloud, self._eyes, self.config.goal_hidden_m)
                if view.hidden:
                    return False, (
                        f"goal refused: hidden {view.depth_m * 100:.0f} cm behind an observed surface from "
                        f"{view.hidden_by} camera(s) and seen past by none, probably inside an object "
                        f"(closed_loop.goal_hidden_m {self.config.goal_hidden_m:.2f} m)"
                    )
        return True, ""

    def fresh_joint_state(self, now: float) -> np.ndarray | None:
        """The measured q (7,) if it is fresh, else None."""
        if self._q is None or now - self._q_time > self.config.stale_joint_states_s:
            return None
        return self._q.copy()

    @property
    def scene(self) -> Any:
        return self._scene

    @property
    def cloud(self) -> np.ndarray | None:
        """The latest cloud (N, 3) [m] as the hard checks take it (at a grasp goal without the target), or None."""
        return self._cloud

    @property
    def raw_cloud(self) -> np.ndarray | None:
        """The latest cloud (N, 3) [m] as received, or None."""
        return self._raw_cloud

    def set_goal(self, goal: Goal, now: float, grasp: GraspSpec | None = None) -> tuple[bool, str]:
        """Accept or refuse a goal; returns (accepted, reason). With `grasp` the goal is a grasp: it may lie at an
        object (no inside-an-obstacle check); its target's points are set aside from the cloud the commands are
        checked against, and the arm moves only along background plans made by planning/grasp.plan_grasp (pre-grasp,
        then a straight approach), never by local steps, which would neither keep the target an obstacle on the
        way nor approach straight. Moving grasp goals are not chased (they are never planned)."""
        if grasp is not None and self.follower is None:
            return False, "grasp goal refused: the closed loop follows no background plans (follow_plans is off)"
        ok, reason = self.check_goal(goal, check_cloud=grasp is None)
        if not ok:
            return False, reason
        changed = self.goal is None or np.linalg.norm(goal.position - self.goal.position) > GOAL_JUMP_M
        if grasp != self.grasp:
            changed = True
            if self.follower is not None:
                self.follower.forget()
        self.goal, self.grasp = goal, grasp
        if changed and self.follower is not None and self._q is not None:  # leaving a grasp: back out first
            self.follower.retreat(self._q, self.planner.config.speed_scale)
        if self._raw_cloud is not None and (changed or grasp is not None):
            self._cloud = self._obstacles(self._raw_cloud)
        if changed:
            self._failed = None
            self._best_err, self._best_time, self._best_goal = np.inf, now, None
        if changed or (self._goal_track and now < self._goal_track[-1][0]):  # a new goal, or the clock went back
            self._goal_track.clear()
        self._goal_track.append((now, np.array(goal.position, dtype=float)))
        while len(self._goal_track) > 2 and now - self._goal_track[1][0] >= GOAL_VELOCITY_WINDOW_S:
            self._goal_track.popleft()
        self._drop_before_reversal()
        return True, "goal accepted"

    def _drop_before_reversal(self) -> None:
        """A goal that turned back (a belt's bounce) drops the goals before the turn from the velocity estimate:
        averaged over the whole window, the estimate (and the lead with it) pointed the old way for up to
        GOAL_VELOCITY_WINDOW_S after the turn. A turn: the newest goal moved against the velocity of the goals
        before it, both faster than STILL_GOAL_MPS (so a still goal's noise is no turn)."""
        track = self._goal_track
        if len(track) < 3:
            return
        (t0, p0), (t1, p1), (t2, p2) = track[0], track[-2], track[-1]
        if t1 - t0 < 0.05 or t2 <= t1:
            return
        before, newest = (p1 - p0) / (t1 - t0), (p2 - p1) / (t2 - t1)
        slow = min(np.linalg.norm(before), np.linalg.norm(newest)) <= STILL_GOAL_MPS
        if not slow and float(np.dot(before, newest)) < 0.0:
            while len(track) > 2:
                track.popleft()

    def goal_velocity(self) -> np.ndarray:
        """The current goal's velocity (3,) [m/s] over the goals of the last GOAL_VELOCITY_WINDOW_S (zeros
        before two goals 50 ms apart)."""
        if len(self._goal_track) < 2:
            return np.zeros(3)
        (t0, p0), (t1, p1) = self._goal_track[0], self._goal_track[-1]
        return (p1 - p0) / (t1 - t0) if t1 - t0 >= 0.05 else np.zeros(3)

    def chased_goal(self) -> Goal | None:
        """The goal the planner chases this tick: the goal led by goal_lead_s of its velocity (capped at
        goal_lead_max_m; none when the led position would be out of reach), or the goal itself."""
        goal, cfg = self.goal, self.config
        if goal is None or cfg.goal_lead_s <= 0.0:
            return goal
        lead = self.goal_velocity() * cfg.goal_lead_s
        norm = float(np.linalg.norm(lead))
        if norm > cfg.goal_lead_max_m:
            lead *= cfg.goal_lead_max_m / norm
        led = replace(goal, position=np.asarray(goal.position, dtype=float) + lead)
        return led if self.check_goal(led, check_cloud=False)[0] else goal

    def clear_goal(self) -> None:
        """Forget the goal (the arm holds until a new one)."""
        self.goal, self.grasp = None, None
        if self._raw_cloud is not None:
            self._cloud = self._obstacles(self._raw_cloud)
        self._goal_track.clear()
        if self.follower is not None:
            self.follower.forget()

    def restart(self, now: float) -> None:
        """Start afresh at time now [s]: clear a failure, restart the progress watchdog and re-encode the measured
        state at the next tick (a planner taking over the closed loop from another)."""
        self._failed = None
        self._best_err, self._best_time, self._best_goal = np.inf, now, None
        self.planner.reset()
        if self.follower is not None:
            self.follower.forget()

    def set_enabled(self, enabled: bool) -> None:
        self.enabled = enabled
        if self.follower is not None:
            self.follower.forget()
        if enabled:
            self._failed = None
            self.planner.reset()

    # -- one tick ---------------------------------------------------------------------------------
    def tick(self, now: float) -> TickOutcome:
        cfg = self.config
        if not self.enabled:
            self._best_time = now  # the no-progress watchdog counts only time spent optimising
            return TickOutcome(None, "disabled", "closed-loop tracking is disabled (call enable)")
        if self._q is None or now - self._q_time > cfg.stale_joint_states_s:
            age = "never received" if self._q is None else f"{now - self._q_time:.2f} s old"
            self._best_time = now
            return TickOutcome(None, "holding", f"no command: joint states {age}", ERROR)
        hold = np.clip(self._q, Q_MIN, Q_MAX)
        if self.goal is None:
            return self._evasion(now, {}, fresh_cloud=True) or TickOutcome(None, "idle", "idle: no goal, no command")
        if self._failed is not None:
            return self._evasion(now, {}, fresh_cloud=True) or TickOutcome(hold, "failed", self._failed, ERROR)
        use_scene = self.planner.config.use_collision
        if use_scene and (self._scene is None or now - self._scene_time > cfg.stale_scene_s):
            age = "never received" if self._scene is None else f"{now - self._scene_time:.2f} s old"
            self._best_time = now
            return TickOutcome(hold, "holding", f"holding: scene {age}", WARN)
        if self.follower is not None:
            outcome = self._follow(now, hold)
            if outcome is not None:
                return outcome
        if self.grasp is not None:
            return self._grasp_hold(now, hold)
        servo_note = ""
        if cfg.servo_radius_m > 0 and float(np.linalg.norm(self.goal_velocity())) > STILL_GOAL_MPS:
            servo = self._servo(now)
            if isinstance(servo, TickOutcome):
                return servo
            servo_note = servo
        t0 = time.perf_counter()
        chased = self.chased_goal()
        assert chased is not None  # self.goal is set
        out = self.planner.step(
            self._q,
            chased,
            self._scene if use_scene else None,
            dt=1.0 / cfg.rate_hz,
            max_iterations=cfg.max_iterations_per_tick,
            budget_s=cfg.tick_budget_ms / 1000.0,
            accepted_steps=cfg.accepted_steps_per_tick,
        )
        tick_ms = (time.perf_counter() - t0) * 1000.0
        err = out.pos_err_m if out.arm_pos_err_m is None else out.arm_pos_err_m  # progress of the arm itself
        values = {
            "pos_err_m": out.pos_err_m,
            "arm_pos_err_m": err,
            "ori_err_deg": float(np.degrees(out.ori_err_rad)),
            "p_collision": out.p_collision,
            "tick_ms": tick_ms,
            "command_source": "local",
            **out.losses,
        }
        if servo_note:
            values["servo_note"] = servo_note
        if self.follower is not None:
            values["plan_note"] = self.follower.note
        moved = self._best_goal is not None and np.linalg.norm(self.goal.position - self._best_goal) > cfg.progress_m
        if out.reached or moved or err < self._best_err - cfg.progress_m:
            # progress, or within tolerance, or the goal moved on (a tracked target): the watchdog restarts
            self._best_err, self._best_time, self._best_goal = err, now, self.goal.position.copy()
        elif not out.reached and now - self._best_time > cfg.no_progress_s:
            self._failed = (
                f"goal not reached: no progress for {cfg.no_progress_s:.0f} s "
                f"(best error {self._best_err * 1000:.0f} mm); holding until a new goal or enable"
            )
            return TickOutcome(hold, "failed", self._failed, ERROR, values)
        evasion = self._evasion(now, values, command=out.command if out.accepted else None)
        if evasion is not None:
            return evasion
        state = "reached" if out.reached else "tracking"
        return TickOutcome(out.command, state, out.reason, OK, values)

    def _follow(self, now: float, hold: np.ndarray) -> TickOutcome | None:
        """The tick's outcome from the background plan: the next hard-checked command along its path, or a hold
        while the plan of a new goal is awaited; None = step locally (see planning/plan_follow.py)."""
        f, q, goal, use_scene = self.follower, self._q, self.goal, self.planner.config.use_collision
        assert f is not None and q is not None and goal is not None  # tick follows only with all three
        scene = self._scene if use_scene else None
        speed = float(np.linalg.norm(self.goal_velocity()))
        if self._scene_after is not None:  # a retreat ended: the target is an obstacle again from the next scene on
            if self._scene_time <= self._scene_after:
                self._best_time = now
                return self._scene_wait(hold, f.note)
            self._scene_after = None
        cloud = self._raw_cloud if self.grasp is not None else self._cloud  # plan_grasp sets the target aside itself
        f.update(now, q, goal, speed, now - self._best_time, scene, cloud, self.grasp, self.cloud_views, self._eyes)
        t0 = time.perf_counter()
        retreating = f.retreating
        target = f.command(q, goal)
        if target is not None:
            if use_scene and scene is not self._checked_scene:  # (a geometric scene costs a distance field)
                self.planner.backend.set_scene(scene)
                self._checked_scene = scene
            if not self.planner.segment_free(q, target, f.escape_from):
                f.drop("its next command collides in the newest scene")
                target = None
        if f.retreat_ended:  # the left grasp's target is an obstacle again
            f.retreat_ended = False
            if self._raw_cloud is not None:
                self._cloud = self._obstacles(self._raw_cloud)
            self._scene_after = self._scene_time
            self._best_time = now
            return self._scene_wait(hold, f.note)
        if target is None:
            if speed <= STILL_GOAL_MPS:  # a still goal already within tolerance: stay (local steps would wander)
                at_goal, pos_err, ori_err = self.planner.arm_at_goal(q, goal)
                if at_goal:
                    self.planner.reset()
                    self._best_err, self._best_time = min(pos_err, self._best_err), now
                    values: dict[str, Any] = {
                        "pos_err_m": pos_err,
                        "arm_pos_err_m": pos_err,
                        "ori_err_deg": float(np.degrees(ori_err)),
                    }
                    return TickOutcome(hold, "reached", "reached", OK, {**values, "command_source": "hold"})
            if f.waiting(now) and speed <= STILL_GOAL_MPS:  # a goal seen moving is chased at once
                self._best_time = now  # waiting for a plan is not a lack of progress
                values = {"command_source": "wait", "plan_note": f.note}
                return TickOutcome(hold, "holding", "holding: waiting for the background plan", OK, values)
            return None
        self.planner.reset()  # local steps re-encode from wherever the path leaves the arm
        reached, pos_err, ori_err = self.planner.arm_at_goal(q, goal)
        values = {
            "pos_err_m": pos_err,
            "arm_pos_err_m": pos_err,
            "ori_err_deg": float(np.degrees(ori_err)),
            "tick_ms": (time.perf_counter() - t0) * 1000.0,
            "command_source": "retreat" if retreating else "plan",
            "plan_note": f.note,
        }
        self._best_err, self._best_time, self._best_goal = min(pos_err, self._best_err), now, goal.position.copy()
        evasion = self._evasion(now, values, command=target)
        if evasion is not None:
            f.drop("evading an approaching obstacle")
            return evasion
        if retreating:
            return TickOutcome(target, "tracking", "retreating along the approach of the grasp left", OK, values)
        reason = "reached" if reached else f"following the background plan ({f.waypoint})"
        return TickOutcome(target, "reached" if reached else "tracking", reason, OK, values)

    @staticmethod
    def _scene_wait(hold: np.ndarray, note: str) -> TickOutcome:
        """Hold after a retreat from a grasp until a scene with its target in it has arrived."""
        values = {"command_source": "wait", "plan_note": note}
        return TickOutcome(hold, "holding", "holding: waiting for a scene with the grasp's target in it", OK, values)

    def _servo(self, now: float) -> TickOutcome | str:
        """The tick's command by IK towards the led goal when the TCP is within servo_radius_m of it (see
        ClosedLoopConfig.servo_radius_m), or why not (a latent step instead; the status's `servo_note`)."""
        cfg, goal, q, own_goal = self.config, self.chased_goal(), self._q, self.goal
        assert goal is not None and q is not None and own_goal is not None  # tick servos only with both
        t0 = time.perf_counter()
        _, pos_err, _ = self.planner.arm_at_goal(q, goal)
        if pos_err > cfg.servo_radius_m:
            return f"{pos_err * 100:.0f} cm from the goal"
        sol = solve_ik(self.planner.panda, goal, q, SERVO_IK)
        delta = sol.q - q
        if float(np.abs(delta).max()) > cfg.servo_max_rad:
            return f"IK asks {float(np.abs(delta).max()):.2f} rad of a joint"
        if sol.pos_err >= pos_err:
            return "IK makes no progress"
        limit = self.planner.config.speed_scale * V_MAX / cfg.rate_hz
        scale = min(1.0, float(np.min(limit / np.maximum(np.abs(delta), 1e-12))))
        command = np.clip(q + scale * delta, Q_MIN, Q_MAX)
        if self.planner.config.use_collision and self._scene is not self._checked_scene:
            self.planner.backend.set_scene(self._scene)
            self._checked_scene = self._scene
        if self._evader is not None:
            least = self._evader.least_clearance(command)
            if least < cfg.servo_clearance_m:
                return f"{least * 100:.1f} cm clearance"
            clearance, speed = self._evader.threat(q)  # an obstacle coming at the arm: the latent steps decide
            if speed >= cfg.evade_approach_mps and clearance < 2.0 * cfg.servo_clearance_m:
                return f"an obstacle approaches at {speed * 100:.0f} cm/s, {clearance * 100:.1f} cm away"
        if not self.planner.segment_free(q, command):
            return "the hard check refuses the segment"
        self.planner.reset()  # the next latent step re-encodes wherever the servo left the arm
        reached, arm_err, ori_err = self.planner.arm_at_goal(q, own_goal)
        values = {
            "pos_err_m": arm_err,
            "arm_pos_err_m": arm_err,
            "ori_err_deg": float(np.degrees(ori_err)),
            "tick_ms": (time.perf_counter() - t0) * 1000.0,
            "command_source": "servo",
        }
        self._best_err, self._best_time, self._best_goal = min(arm_err, self._best_err), now, own_goal.position.copy()
        evasion = self._evasion(now, values, command=command)
        if evasion is not None:
            return evasion
        return TickOutcome(command, "reached" if reached else "tracking", "servoing by IK", OK, values)

    def _grasp_hold(self, now: float, hold: np.ndarray) -> TickOutcome:
        """The tick at a grasp goal without a path to follow: hold (a grasp is approached along background plans
        only); the goal is given up after no_progress_s without one."""
        cfg, f = self.config, self.follower
        assert f is not None  # a grasp goal is taken only with a follower
        values = {"command_source": "hold", "plan_note": f.note, "grasp": self.grasp_note}
        if now - self._best_time > cfg.no_progress_s:
            self._failed = (
                f"grasp goal not reached: no plan to follow for {cfg.no_progress_s:.0f} s ({f.note}); holding until "
                "a new goal or enable"
            )
            return TickOutcome(hold, "failed", self._failed, ERROR, values)
        return TickOutcome(hold, "holding", f"holding: a grasp goal is approached along a plan only ({f.note})", WARN,
                           values)  # fmt: skip

    def _evasion(
        self, now: float, values: dict[str, Any], fresh_cloud: bool = False, command: np.ndarray | None = None
    ) -> TickOutcome | None:
        """A retreat from an observed obstacle approaching the arm, or None (see evade_margin_m). command (7,)
        [rad]: the planner's step, kept when it gains clearance faster than the obstacle approaches; with
        fresh_cloud, only when the newest cloud is at most stale_scene_s old (holds without planning)."""
        cfg = self.config
        if cfg.evade_margin_m <= 0 or self._evader is None:
            return None
        if fresh_cloud and now - self._evader.newest_time > cfg.stale_scene_s:
            return None
        q = self._q
        assert q is not None  # tick evades only with a joint state
        clearance, speed = self._evader.threat(q)
        values.update(clearance_m=clearance, approach_mps=speed)
        if clearance >= cfg.evade_margin_m or speed < cfg.evade_approach_mps:
            return None
        # the step is kept when it gains more clearance than the obstacle takes in a control period (the points it
        # nears move on too: a step that merely edges away is overrun by a fast obstacle)
        if command is not None and self._evader.least_clearance(command) - speed / cfg.rate_hz > clearance:
            return None
        q_new = self._evader.retreat(q, self.planner.config.speed_scale * V_MAX / cfg.rate_hz)
        if q_new is None:
            return None
        self.planner.reset()  # re-encode where the arm went, with fresh loss weights
        self._best_time = now  # a forced retreat is not a lack of progress
        reason = f"evading: an observed obstacle approaches at {speed * 100:.0f} cm/s, {clearance * 100:.1f} cm away"
        return TickOutcome(q_new, "evading", reason, WARN, values)

"""Planner modes of the closed loop: AMP-LS on the observed scene, or LSPP while cylinder obstacles are known.

ROS-free: the planner node holds two closed loops, one per planner, and hands this class its inputs. With no
cylinders the AMP-LS loop runs exactly as on its own. A non-empty cylinder set switches the closed loop and
one-shot plans to LSPP (the same core planner on the cylinder classifier, position-only goals); the scene
(cloud or embedding) is then not needed, so a silent camera does not make the arm hold. Cylinders are latched
state: they stay until replaced or cleared, and never go stale. At a switch the loop that takes over restarts
its search and watchdog on the current goal.
"""

from __future__ import annotations

import numpy as np

from latent_planner_ros.data.cylinders import validate_cylinders
from latent_planner_ros.planning.closed_loop import ClosedLoopController, TickOutcome
from latent_planner_ros.planning.goal import Goal
from latent_planner_ros.planning.grasp import GraspSpec

AMP_LS, LSPP = "amp_ls", "lspp"


def goal_in_cylinders(position: np.ndarray, cylinders: np.ndarray, clearance_m: float) -> int:
    """Index of the first cylinder (K, 4) (x, y, h, r) [m] whose volume grown by clearance_m [m] holds the
    point position (3,) [m], or -1."""
    if len(cylinders) == 0:
        return -1
    radial = np.linalg.norm(cylinders[:, :2] - position[:2], axis=1)
    inside = (radial < cylinders[:, 3] + clearance_m) & (position[2] < cylinders[:, 2] + clearance_m)
    return int(np.argmax(inside)) if inside.any() else -1


class PlannerModes:
    """The closed loop of AMP-LS, or of LSPP while cylinders are set; times are seconds on one clock.

    Args:
        amp_ls: the closed loop of the point-cloud planner (learned, geometric or no backend).
        lspp: the closed loop of an LSPP planner (cylinder backend, position-only goals).
    """

    def __init__(self, amp_ls: ClosedLoopController, lspp: ClosedLoopController):
        self.amp_ls, self.lspp = amp_ls, lspp
        self.cylinders = np.zeros((0, 4))
        self.goal: Goal | None = None
        self.grasp: GraspSpec | None = None  # the goal is a grasp (AMP-LS mode only)

    @property
    def mode(self) -> str:
        """LSPP while cylinders are set, else AMP_LS."""
        return LSPP if len(self.cylinders) else AMP_LS

    @property
    def active(self) -> ClosedLoopController:
        """The closed loop of the current mode."""
        return self.lspp if self.mode == LSPP else self.amp_ls

    def describe(self) -> str:
        """The mode for a status topic, e.g. "lspp (3 cylinders; goals: position only)" or "amp_ls"."""
        if self.mode == AMP_LS:
            return AMP_LS
        k = len(self.cylinders)
        return f"{LSPP} ({k} cylinder{'s' if k != 1 else ''}; goals: position only)"

    # -- inputs ---------------------------------------------------------------------------------------------
    def set_cylinders(self, cylinders: np.ndarray, now: float) -> str:
        """Replace the obstacle set with cylinders (K, 4) (x, y, h, r) [m] (empty: back to AMP-LS).

        Returns "" or why the current goal was dropped (it lies inside a cylinder). Raises ValueError for a
        malformed set (nothing changes then).
        """
        cylinders = validate_cylinders(cylinders)
        before = self.mode
        self.cylinders = cylinders
        if len(cylinders):
            self.lspp.set_scene(cylinders, now)
        if self.mode != before:
            self.active.restart(now)
            if self.goal is not None and self.grasp is not None and self.mode == LSPP:
                self._drop_goal()
                return "grasp goal dropped: cylinder obstacles switch to LSPP, which plans position-only goals"
            if self.goal is not None:
                ok, reason = self.check_goal(self.goal)
                if not ok:
                    self._drop_goal()
                    return reason
                self.active.set_goal(self.goal, now, self.grasp)
            return ""
        if self.goal is not None and self.mode == LSPP:
            ok, reason = self.check_goal(self.goal)
            if not ok:
                self._drop_goal()
                return reason
        return ""

    def _drop_goal(self) -> None:
        self.goal, self.grasp = None, None
        self.amp_ls.clear_goal()
        self.lspp.clear_goal()

    def set_joint_state(self, q: np.ndarray, now: float) -> tuple[bool, str]:
        """The measured q (7,) [rad] for both loops; (accepted, reason) as ClosedLoopController.set_joint_state."""
        self.lspp.set_joint_state(q, now)
        return self.amp_ls.set_joint_state(q, now)

    def check_goal(self, goal: Goal) -> tuple[bool, str]:
        """The active loop's goal checks, and (LSPP) a goal inside a cylinder is refused."""
        ok, reason = self.active.check_goal(goal)
        if not ok or self.mode == AMP_LS:
            return ok, reason
        i = goal_in_cylinders(goal.position, self.cylinders, self.active.config.goal_clearance_m)
        if i >= 0:
            x, y, h, r = self.cylinders[i]
            return False, f"goal refused: inside cylinder obstacle {i} (x {x:.2f}, y {y:.2f}, h {h:.2f}, r {r:.2f} m)"
        return True, ""

    def set_goal(self, goal: Goal, now: float, grasp: GraspSpec | None = None) -> tuple[bool, str]:
        """Accept or refuse a goal for the active loop; the other loop takes it over at a mode switch. A grasp
        goal (`grasp`, see ClosedLoopController.set_goal) needs the point cloud: refused in LSPP mode."""
        if grasp is not None:
            if self.mode == LSPP:
                return False, "grasp goal refused: cylinder obstacles are set (LSPP plans position-only goals)"
            ok, reason = self.amp_ls.set_goal(goal, now, grasp)
        else:
            ok, reason = self.check_goal(goal)
            if ok:
                ok, reason = self.active.set_goal(goal, now)
        if ok:
            self.goal, self.grasp = goal, grasp
        return ok, reason

    def set_enabled(self, enabled: bool) -> None:
        self.amp_ls.set_enabled(enabled)
        self.lspp.set_enabled(enabled)

    # -- one tick -----------------------------------------------------------------------------------------
    def tick(self, now: float) -> TickOutcome:
        """One tick of the active loop; the latched cylinders count as a fresh scene."""
        if self.mode == LSPP:
            self.lspp.set_scene(self.cylinders, now)
        return self.active.tick(now)

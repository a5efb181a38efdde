"""PlannerModes: AMP-LS without cylinders, LSPP with them (no scene needed), goal hand-over and refusals."""

import math

import numpy as np
import pytest

from latent_planner_ros.planning.amp_ls import AmpLsConfig, StepResult, presets
from latent_planner_ros.planning.closed_loop import ClosedLoopConfig, ClosedLoopController
from latent_planner_ros.planning.goal import Goal
from latent_planner_ros.planning.planner_modes import AMP_LS, LSPP, PlannerModes, goal_in_cylinders
from latent_planner_ros.robot.limits import Q_READY


class _Planner:
    """Records what each step saw (AmpLs.step's interface); its error shrinks 1 cm a step, never reaching."""

    def __init__(self, name: str, config: AmpLsConfig):
        self.name, self.config = name, config
        self.steps: list[tuple[np.ndarray, object]] = []
        self.resets = 0

    def reset(self) -> None:
        self.resets += 1

    def step(self, q, goal, scene, dt, max_iterations, budget_s=None, accepted_steps=1):
        self.steps.append((goal.position.copy(), scene))
        return StepResult(np.asarray(q), True, False, 1.0 - 0.01 * len(self.steps), 0.0, 0.0, "tracking", {})


def _modes(**cfg):
    amp = ClosedLoopController(_Planner(AMP_LS, AmpLsConfig(collision_backend="geometric")), ClosedLoopConfig(**cfg))
    lspp = ClosedLoopController(_Planner(LSPP, presets.lspp()), ClosedLoopConfig(**cfg))
    return PlannerModes(amp, lspp)


GOAL = Goal(np.array([0.5, 0.2, 0.3]), np.eye(3))
ONE = np.array([[0.5, -0.2, 0.4, 0.05]])


def test_no_cylinders_is_amp_ls_and_holds_for_a_missing_scene():
    m = _modes()
    m.set_joint_state(Q_READY, 0.0)
    assert m.set_goal(GOAL, 0.0) == (True, "goal accepted")
    out = m.tick(0.1)
    assert m.mode == AMP_LS and m.describe() == "amp_ls" and m.active is m.amp_ls
    assert out.state == "holding" and "scene never received" in out.reason
    assert m.lspp.planner.steps == []


def test_cylinders_switch_to_lspp_which_needs_no_scene():
    m = _modes()
    m.set_joint_state(Q_READY, 0.0)
    m.set_goal(GOAL, 0.0)
    assert m.set_cylinders(ONE, 0.05) == ""
    assert m.mode == LSPP and m.describe() == "lspp (1 cylinder; goals: position only)"
    assert m.lspp.planner.resets == 1  # the taking-over loop re-encodes the measured state
    for t in (0.1, 5.0, 50.0):  # latched: the cylinders never go stale
        m.set_joint_state(Q_READY, t)
        out = m.tick(t)
        assert out.state == "tracking", out.reason
    goal_pos, scene = m.lspp.planner.steps[-1]
    np.testing.assert_array_equal(goal_pos, GOAL.position)  # the goal was handed over
    np.testing.assert_array_equal(scene, ONE)
    assert m.amp_ls.planner.steps == []
    m.set_cylinders(np.vstack([ONE, ONE + [0.0, 0.4, 0.0, 0.0]]), 51.0)
    assert m.describe().startswith("lspp (2 cylinders")


def test_empty_set_returns_to_amp_ls_with_the_goal():
    m = _modes()
    m.set_cylinders(ONE, 0.0)
    m.set_goal(GOAL, 0.0)
    assert m.amp_ls.goal is None and m.lspp.goal is GOAL
    m.set_cylinders(np.zeros((0, 4)), 1.0)
    assert m.mode == AMP_LS and m.amp_ls.goal is GOAL


def test_goal_inside_a_cylinder_is_refused_or_dropped():
    m = _modes()
    m.set_cylinders(ONE, 0.0)
    inside = Goal(np.array([0.52, -0.2, 0.3]), np.eye(3))
    ok, reason = m.set_goal(inside, 0.0)
    assert not ok and "inside cylinder obstacle 0" in reason
    assert m.set_goal(GOAL, 0.0)[0]
    # a cylinder placed on the goal drops it: the arm holds rather than chase an unreachable goal
    reason = m.set_cylinders(np.array([[0.5, 0.2, 0.5, 0.05]]), 1.0)
    assert "inside cylinder obstacle 0" in reason and m.goal is None and m.lspp.goal is None
    m.set_joint_state(Q_READY, 1.0)
    assert m.tick(1.1).reason == "idle: no goal, no command"


def test_malformed_cylinders_change_nothing():
    m = _modes()
    m.set_cylinders(ONE, 0.0)
    with pytest.raises(ValueError, match="finite"):
        m.set_cylinders(np.array([[math.nan, 0.0, 0.4, 0.05]]), 1.0)
    np.testing.assert_array_equal(m.cylinders, ONE)


def test_enable_reaches_both_loops():
    m = _modes()
    m.set_enabled(False)
    assert not m.amp_ls.enabled and not m.lspp.enabled


def test_goal_in_cylinders():
    cyl = np.array([[0.5, 0.0, 0.3, 0.05], [0.0, 0.5, 0.6, 0.1]])
    assert goal_in_cylinders(np.array([0.5, 0.04, 0.2]), cyl, 0.0) == 0
    assert goal_in_cylinders(np.array([0.0, 0.5, 0.605]), cyl, 0.01) == 1
    assert goal_in_cylinders(np.array([0.5, 0.0, 0.35]), cyl, 0.01) == -1  # above the top
    assert goal_in_cylinders(np.array([0.5, 0.07, 0.2]), cyl, 0.01) == -1  # beside it
    assert goal_in_cylinders(np.zeros(3), np.zeros((0, 4)), 0.01) == -1

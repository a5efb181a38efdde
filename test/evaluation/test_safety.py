"""The safety invariant: finite, inside the joint limits, within one period at V_MAX of the measured state."""

import numpy as np

from latent_planner_ros.evaluation.safety import SafetyConfig, SafetyMonitor, command_positions
from latent_planner_ros.robot.limits import JOINT_NAMES, Q_MAX, Q_READY, V_MAX


def _cmd(monitor, t, q, names=JOINT_NAMES):
    return monitor.on_command(t, list(names), list(np.asarray(q, dtype=float)))


def test_a_small_step_from_the_measured_state_is_safe():
    m = SafetyMonitor()
    m.on_state(0.0, Q_READY)
    assert _cmd(m, 0.05, Q_READY + 0.5 * V_MAX * 0.1) == []
    assert m.summary()["violations"] == 0 and m.summary()["commands"] == 1
    assert 0.4 < m.max_step_ratio < 0.5


def test_each_rule_is_reported_with_its_kind():
    m = SafetyMonitor()
    m.on_state(0.0, Q_READY)
    nan = Q_READY.copy()
    nan[2] = np.nan
    beyond = Q_READY.copy()
    beyond[0] = Q_MAX[0] + 0.01
    fast = Q_READY.copy()
    fast[4] += V_MAX[4] * 0.1 + 0.03
    assert _cmd(m, 0.01, nan)[0].kind == "non_finite"
    assert _cmd(m, 0.02, beyond)[0].kind == "joint_limit"
    v = _cmd(m, 0.03, fast)[0]
    assert v.kind == "velocity" and "panda_joint5" in v.detail
    assert _cmd(m, 0.04, Q_READY[:6], JOINT_NAMES[:6])[0].kind == "malformed"
    assert m.counts() == {"malformed": 1, "non_finite": 1, "joint_limit": 1, "velocity": 1}


def test_names_are_matched_not_positions():
    order = [6, 2, 0, 5, 1, 4, 3]
    q = command_positions([JOINT_NAMES[i] for i in order] + ["panda_finger_joint1"], [*Q_READY[order], 0.04])
    np.testing.assert_allclose(q, Q_READY)


def test_a_command_may_answer_a_state_measured_one_latency_earlier():
    """A jump of the measured state (a sim reset) does not flag the command computed just before it."""
    m = SafetyMonitor(SafetyConfig(latency_s=0.15))
    before = Q_READY + 0.8
    before[3] = -1.5
    m.on_state(0.00, before)
    m.on_state(0.05, Q_READY)  # reset: the arm is back at the start
    assert _cmd(m, 0.06, before) == []  # computed from the old state
    assert _cmd(m, 0.30, before)[0].kind == "velocity"  # the old state is out of the window now


def test_commands_before_any_state_are_counted_unchecked():
    m = SafetyMonitor()
    assert _cmd(m, 0.0, Q_READY) == []
    assert m.unchecked_velocity == 1


def test_a_known_jump_lets_commands_answer_the_states_before_it_for_a_while():
    m = SafetyMonitor(SafetyConfig(latency_s=0.15, jump_grace_s=0.5))
    before = Q_READY + 0.8
    before[3] = -1.5
    m.on_state(0.00, before)
    m.note_jump(0.01)
    for t in np.arange(0.02, 0.5, 0.01):
        m.on_state(t, Q_READY)
    assert _cmd(m, 0.4, before) == []  # a slow planner's command computed before the reset
    assert _cmd(m, 0.6, before)[0].kind == "velocity"

"""Trial metrics on synthetic time series: reaching, tracking a moving target, the success rule, ticks, plots."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from latent_planner_ros.evaluation.trial import (
    SuccessRule,
    TrialLog,
    contact_events,
    format_summary,
    longest_command_gap,
    missed_ticks,
    plot_tracking,
    target_at,
    tick_samples,
    tracking,
    trial_metrics,
    within_runs,
)
from latent_planner_ros.robot.limits import Q_READY
from latent_planner_ros.robot.panda import load_panda

DOWN = np.array([1.0, 0.0, 0.0, 0.0])  # the ready pose's TCP orientation (pointing down)


def synthetic_log(offset, duration=6.0, quat=None, contact_at=(), commands=None, ticks=None) -> TrialLog:
    """The arm holds the ready pose; the target is the ready TCP position + offset(t) [m] (moving when offset
    varies), sampled at 12.5 Hz; joint states at 100 Hz; contact True at the given times."""
    ee = load_panda().fk(Q_READY).translation
    jt = np.round(np.arange(0.01, duration + 1e-9, 0.01), 6)
    tt = np.round(np.arange(0.0, duration + 1e-9, 0.08), 6)
    contact = np.zeros(len(jt), dtype=bool)
    for t in contact_at:
        contact[np.argmin(np.abs(jt - t))] = True
    cmd = np.round(np.arange(0.05, duration, 0.1), 6) if commands is None else np.asarray(commands, float)
    tick = np.full(len(cmd), 40.0) if ticks is None else np.asarray(ticks, float)
    return TrialLog(
        duration_s=duration,
        joint_t=jt,
        q=np.tile(Q_READY, (len(jt), 1)),
        target_t=tt,
        target_position=ee + np.array([offset(t) for t in tt]),
        target_quaternion=np.tile(DOWN if quat is None else quat, (len(tt), 1)),
        contact_t=jt,
        contact=contact,
        distance_t=jt,
        distance=np.linspace(0.2, 0.05, len(jt)),
        status_t=cmd[: len(tick)],
        status_state=("tracking",) * len(tick),
        status_message=("tracking: ok",) * len(tick),
        tick_ms=tick,
        command_t=cmd,
    )


def approaching(t: float) -> np.ndarray:
    """10 cm away along y at t = 0, closing at 10 cm/s until it is at the end effector (t >= 1)."""
    return np.array([0.0, 0.1 * max(0.0, 1.0 - t), 0.0])


def test_target_interpolates_between_samples_and_holds_across_a_jump():
    tt = np.array([0.0, 1.0, 2.0])
    pos = np.array([[0.0, 0.0, 0.0], [0.0, 0.04, 0.0], [0.0, -0.5, 0.0]])  # 4 cm/s, then a wrap-round jump
    quat = np.tile(DOWN, (3, 1))
    p, rot, known = target_at(np.array([-0.5, 0.5, 1.5, 3.0]), tt, pos, quat)
    assert known.tolist() == [False, True, True, True]
    assert p[1] == pytest.approx([0.0, 0.02, 0.0])
    assert p[2] == pytest.approx([0.0, 0.04, 0.0])  # no interpolation across the jump
    assert p[3] == pytest.approx([0.0, -0.5, 0.0])
    assert rot[1] == pytest.approx(np.diag([1.0, -1.0, -1.0]))


def test_within_runs_and_contact_events():
    t = np.arange(10) * 0.1
    inside = np.array([0, 1, 1, 0, 0, 1, 1, 1, 1, 1], bool)
    assert np.array(within_runs(t, inside, end_s=1.0)) == pytest.approx(np.array([(0.1, 0.3), (0.5, 1.0)]))
    assert within_runs(t, np.zeros(10, bool), 1.0) == []
    assert contact_events(np.array([1, 1, 0, 1, 0, 0, 1], bool)) == 3
    assert contact_events(np.zeros(0, bool)) == 0


def test_reaching_then_tracking_a_moving_target_is_a_success():
    m = trial_metrics(synthetic_log(approaching))
    # within 3 cm once 0.1 * (1 - t) <= 0.03, i.e. from t = 0.7 s (the first joint sample at or after it)
    assert m["reached"] and m["tracked"] and m["success"]
    assert m["time_to_reach_s"] == pytest.approx(0.7, abs=0.015)
    assert m["time_to_track_s"] == pytest.approx(m["time_to_reach_s"])
    assert m["tracking_fraction"] == pytest.approx(1.0, abs=0.01)
    assert m["final_pos_err_m"] == pytest.approx(0.0, abs=1e-9)
    assert m["collisions"] == 0 and not m["collided"]
    assert m["min_obstacle_distance_m"] == pytest.approx(0.05)


def test_passing_by_is_reached_but_not_tracked():
    """The target passes the end effector at 5 cm/s: within 3 cm for 1.2 s only (< the 2 s hold)."""
    m = trial_metrics(synthetic_log(lambda t: np.array([0.0, 0.1 - 0.05 * t, 0.0])))
    assert m["reached"] and not m["tracked"] and not m["success"]
    assert m["time_to_reach_s"] == pytest.approx(1.4, abs=0.015)
    assert m["longest_within_s"] == pytest.approx(1.2, abs=0.03)
    assert m["time_to_track_s"] is None
    assert 0.0 < m["tracking_fraction"] < 0.5


def test_orientation_outside_tolerance_is_never_reached():
    tilted = (Rotation.from_quat(DOWN) * Rotation.from_euler("x", 25, degrees=True)).as_quat()
    m = trial_metrics(synthetic_log(lambda t: np.zeros(3), quat=tilted))
    assert not m["reached"] and not m["success"] and m["time_to_reach_s"] is None
    assert m["final_ori_err_deg"] == pytest.approx(25.0, abs=0.01)
    assert m["final_pos_err_m"] == pytest.approx(0.0, abs=1e-9)
    # a looser rule accepts it
    assert trial_metrics(synthetic_log(lambda t: np.zeros(3), quat=tilted), SuccessRule(ori_tol_deg=30.0))["success"]


def test_a_contact_at_any_time_fails_an_otherwise_tracked_trial():
    m = trial_metrics(synthetic_log(approaching, contact_at=(5.5,)))
    assert m["tracked"] and m["collided"] and not m["success"]
    assert m["collisions"] == 1 and m["contact_s"] == pytest.approx(0.01)


def test_tick_statistics_and_missed_ticks():
    ticks = [2000.0, 50.0, 50.0, 60.0, 70.0]  # 50 twice in a row: one tick reported twice
    assert tick_samples(np.array([np.nan, *ticks])).tolist() == [2000.0, 50.0, 60.0, 70.0]
    assert missed_ticks(np.arange(0.05, 6.0, 0.1), 0.1, 6.0) == 0
    cmds = np.r_[np.arange(0.05, 2.0, 0.1), np.arange(2.55, 6.0, 0.1)]  # 0.5 s without commands
    assert missed_ticks(cmds, 0.1, 6.0) == 5
    late = np.arange(0.05, 6.0, 0.1)
    late[10] += 0.06  # a late tick is not a missed one
    assert missed_ticks(late, 0.1, 6.0) == 0
    assert missed_ticks(np.arange(1.05, 6.0, 0.1), 0.1, 6.0) == 10  # the first second without commands
    # a window edge between two jittered ticks: up to half a period beyond one period is jitter, not a miss
    jittered = np.arange(0.12, 5.95, 0.1)  # first tick 0.12 s after the start, last 0.09 s before the end
    assert missed_ticks(jittered, 0.1, 6.0) == 0
    assert missed_ticks(jittered[1:], 0.1, 6.0) == 1 and missed_ticks(jittered[:-2], 0.1, 6.0) == 2
    assert longest_command_gap(cmds, 6.0) == pytest.approx(0.6)
    assert longest_command_gap(np.array([1.0]), 6.0) is None
    assert missed_ticks(np.zeros(0), 0.1, 6.0) == 60
    m = trial_metrics(synthetic_log(approaching, commands=cmds, ticks=np.full(len(cmds), 40.0)))
    assert m["missed_ticks"] == 5
    assert m["tick_ms_p50"] == pytest.approx(40.0) and m["first_tick_ms"] == pytest.approx(40.0)


def test_summary_has_every_field_and_reads_honestly(tmp_path):
    log = synthetic_log(lambda t: np.array([0.0, 0.1 - 0.05 * t, 0.0]))
    tr = tracking(log)
    m = trial_metrics(log, track=tr)
    for key in (
        "reached",
        "tracked",
        "success",
        "time_to_reach_s",
        "tracking_fraction",
        "min_obstacle_distance_m",
        "collisions",
        "tick_ms_p50",
        "tick_ms_p99",
        "missed_ticks",
        "command_gap_max_s",
        "planner_states",
    ):
        assert key in m, key
    text = format_summary(m)
    assert "but NOT tracked" in text and "success          no" in text
    fig = plot_tracking(tr, m, title="synthetic")
    fig.savefig(tmp_path / "tracking.png")
    assert (tmp_path / "tracking.png").stat().st_size > 10_000


def test_an_empty_trial_has_undefined_figures_not_errors():
    m = trial_metrics(TrialLog(duration_s=5.0))
    assert not m["reached"] and not m["success"]
    assert m["time_to_reach_s"] is None and m["min_obstacle_distance_m"] is None and m["tick_ms_p50"] is None
    assert m["missed_ticks"] == 50 and m["command_sources"] == {}
    assert "NOT reached" in format_summary(m)


def test_command_sources_are_the_shares_of_the_statuses_that_name_one():
    log = TrialLog(duration_s=1.0, status_source=("local", "", "servo", "servo", "plan"))
    assert trial_metrics(log)["command_sources"] == {"local": 0.25, "plan": 0.25, "servo": 0.5}


def test_servo_notes_are_counted_by_kind_over_all_statuses():
    notes = ("3.2 cm clearance", "", "4.9 cm clearance", "12 cm from the goal")
    m = trial_metrics(TrialLog(duration_s=1.0, status_servo_note=notes))
    assert m["servo_notes"] == {"# cm clearance": 0.5, "# cm from the goal": 0.25}
    assert trial_metrics(TrialLog(duration_s=1.0))["servo_notes"] == {}

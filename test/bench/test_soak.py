"""bench soak: the seeded workload, the report's figures from synthetic time series, and a short real run."""

from __future__ import annotations

import json
import os

import numpy as np
import pytest

from latent_planner_ros.evaluation.soak_procfs import group_usage, process_usage
from latent_planner_ros.evaluation.soak_report import (
    GoalSent,
    SoakLog,
    classify_goals,
    growth_pct_per_hour,
    markdown,
    minute_ticks,
    missed_periods,
    summarise,
)
from latent_planner_ros.evaluation.soak_workload import (
    BAD_PARAMS,
    EVENT_KINDS,
    GOAL_KINDS,
    GOOD_PARAMS,
    GRASP_SPARE_M,
    HAND_HALF_OPENING_M,
    SHOULDER,
    Event,
    WorkloadConfig,
    counts,
    generate,
    grasp_candidates,
    object_top_z,
    resolve_pose,
    spans_a_switch,
    still_objects,
)
from latent_planner_ros.robot.rotations import quat_to_matrix
from sim_bridge.scenario_files import load_scenario

REQUIRED = (
    "minutes",
    "invariant_violations",
    "contacts",
    "node_crashes",
    "rss_growth_pct_per_hour_max",
    "tick_ms_p99_max_minute",
    "goals_without_outcome",
)


# ------------------------------------------------------------------------------------------------ workload
def test_workload_is_seeded_and_covers_every_event_kind():
    a, b, c = generate(30, seed=3), generate(30, seed=3), generate(30, seed=4)
    assert [e.to_dict() for e in a] == [e.to_dict() for e in b]
    assert [e.to_dict() for e in a] != [e.to_dict() for e in c]
    n = counts(a)
    assert all(n[k] > 0 for k in EVENT_KINDS), n
    assert all(n[f"goal:{g}"] > 0 for g in GOAL_KINDS), n
    assert [e.t for e in a] == sorted(e.t for e in a) and a[0].kind == "scenario" and a[0].t == 0.0
    # a short run still gets one of every periodic kind and both scenarios
    short = counts(generate(0.5, seed=0))
    assert all(short[k] > 0 for k in ("scenario", "camera_dropout", "joint_pause", "param_change", "plan_request"))
    assert short["scenario"] == 2


def test_no_joint_state_pause_spans_a_scenario_switch():
    """A switch resets the sim (the arm jumps back to its start), which a planner without joint states cannot see:
    seed 0's 60-minute workload had a switch at 277.5 s, 0.2 s into a 0.56 s pause (soak60c). Pauses are still
    drawn."""
    for seed in (0, 1, 2):
        events = generate(60, seed=seed)
        switches = np.array([e.t for e in events if e.kind == "scenario"])
        pauses = [e for e in events if e.kind == "joint_pause"]
        assert len(pauses) > 30
        for e in pauses:
            assert not np.any((switches >= e.t - 0.1) & (switches <= e.t + e.params["duration_s"] + 0.1)), e
    switches = np.array([e.t for e in generate(60, seed=0) if e.kind == "scenario"])
    assert spans_a_switch(Event(277.3, "joint_pause", {"duration_s": 0.56}), np.array([277.48]))
    assert not spans_a_switch(Event(276.0, "joint_pause", {"duration_s": 0.56}), np.array([277.48]))
    assert any(abs(t - 277.48) < 0.01 for t in switches)  # the switch of soak60c is still there


def test_workload_values_lie_in_their_ranges():
    cfg = WorkloadConfig()
    events = generate(60, seed=11, config=cfg)
    goals = [e for e in events if e.kind in ("goal", "grasp_goal")]
    gaps = np.diff([e.t for e in goals])
    assert gaps.min() >= cfg.goal_interval_s[0] and gaps.max() <= cfg.goal_interval_s[1]
    phases = [(e.t, e.params["scenario"]) for e in events if e.kind == "scenario"]
    assert [s for _, s in phases[:4]] == ["tabletop", "conveyor", "tabletop", "conveyor"]

    def scenario_at(t):
        return [s for start, s in phases if start <= t][-1]

    for e in events:
        p = e.params
        if e.kind == "camera_dropout":
            assert cfg.dropout_s[0] <= p["duration_s"] <= cfg.dropout_s[1]
        elif e.kind == "joint_pause":
            assert cfg.pause_s[0] <= p["duration_s"] <= cfg.pause_s[1]
        elif e.kind == "param_change" and p["expect"] == "accepted":
            lo, hi = GOOD_PARAMS[p["name"]]
            assert lo <= p["value"] <= hi
        elif e.kind == "param_change":
            assert (p["name"], p["value"]) in BAD_PARAMS
        elif e.kind == "grasp_goal" or p.get("goal") == "inside_obstacle":
            assert scenario_at(e.t) == "tabletop"
        elif p.get("goal") == "conveyor_target":
            assert scenario_at(e.t) == "conveyor"
        elif p.get("goal") == "unreachable":
            assert np.linalg.norm(np.subtract(p["position"], SHOULDER)) > 1.05  # the planner's reach_m
        elif p.get("goal") == "reachable":
            assert np.all(np.array(cfg.reach_box[0]) <= p["position"])
            assert np.all(p["position"] <= np.array(cfg.reach_box[1]))


def test_object_goals_resolve_against_the_scene():
    scene = load_scenario("tabletop", seed=3)
    objects = still_objects(scene)
    inside = resolve_pose(Event(1.0, "goal", {"goal": "inside_obstacle", "object_u": 0.0, "surface": False}), scene)
    assert np.allclose(inside[0], objects[0].position)
    top = resolve_pose(Event(1.0, "goal", {"goal": "inside_obstacle", "object_u": 0.0, "surface": True}), scene)
    assert top[0][2] == pytest.approx(object_top_z(objects[0]) - 0.005)
    box = next(o for o in objects if o.type == "box")
    assert object_top_z(box) > box.position[2]
    scene = load_scenario("tabletop", seed=9)  # a box lying turned on the table, narrow along its y axis
    (box, _), *_ = [(o, y) for o, y in grasp_candidates(scene) if o.type == "box"]
    grasp = resolve_pose(Event(1.0, "grasp_goal", {"object_u": 0.0}), scene)
    assert np.allclose(grasp[0][:2], box.position[:2]) and grasp[0][2] == pytest.approx(object_top_z(box) - 0.025)
    r = quat_to_matrix(grasp[1][None])[0]
    assert np.allclose(r[:, 2], [0.0, 0.0, -1.0])  # the hand points down
    narrow = quat_to_matrix(np.asarray(box.quaternion_xyzw)[None])[0][:, 1]
    assert abs(r[:, 1] @ narrow) == pytest.approx(1.0)  # the fingers close across the narrow side
    assert box.half_extents[1] <= HAND_HALF_OPENING_M - GRASP_SPARE_M
    assert all(o.radius <= 0.03 for o, _ in grasp_candidates(load_scenario("tabletop", seed=0)) if o.type != "box")
    assert resolve_pose(Event(1.0, "grasp_goal", {"object_u": 0.5}), load_scenario("tabletop", seed=1)) is None
    assert resolve_pose(Event(1.0, "goal", {"goal": "conveyor_target"}), scene) is None
    assert [o.name for o in still_objects(load_scenario("conveyor", seed=1))] == ["belt"]  # target, obstacle move


# ------------------------------------------------------------------------------------------------ report
def _status(t, state="tracking", last_error="", tick_ms=float("nan"), message=None):
    return (t, state, message or f"{state}: x", last_error, tick_ms)


def test_minute_ticks_and_missed_periods():
    rng = np.random.default_rng(0)
    minute0 = [
        _status(t, tick_ms=float(v)) for t, v in zip(np.arange(0, 60, 0.1), rng.uniform(5, 15, 600), strict=True)
    ]
    minute1 = [_status(60 + 0.1 * k, tick_ms=20.0 + k) for k in range(100)]  # 20..119 ms
    ticks = minute_ticks(minute0 + minute1 + [_status(150.0)], 150.0)
    assert [m["minute"] for m in ticks] == [0, 1, 2]
    assert ticks[0]["ticks"] == 600 and 5 <= ticks[0]["p50"] <= 15
    assert ticks[1]["max"] == 119.0 and ticks[1]["p99"] == pytest.approx(np.percentile(np.arange(20, 120), 99))
    assert ticks[2]["ticks"] == 0 and ticks[2]["p99"] is None

    commands = list(np.round(np.arange(0, 30, 0.1), 3))
    commands = [c for c in commands if not 5.0 < c < 5.5]  # a gap 5.0 -> 5.5: 4 periods missed
    commands = [c for c in commands if not 20.0 < c < 21.0]  # 20.0 -> 21.0: 9 periods, excused
    commands += [65.0, 65.1, 65.3]  # 29.9 -> 65.0: 350 missed (minute 0), then 65.1 -> 65.3: 1 (minute 1)
    per_minute, missed, excused = missed_periods(commands, 0.1, [(19.8, 20.5)], 120.0)
    assert excused == 9
    assert per_minute == [4 + 350, 1] and missed == 355


def test_growth_per_hour_after_warmup():
    t = np.arange(0.0, 600.0, 10.0)
    rss = np.where(t < 120, 50.0 + t, 200.0 + 0.01 * (t - 120))  # warm-up ramp, then 0.01 MB/s from 200 MB
    g = growth_pct_per_hour(t, rss, 120.0)
    assert g == pytest.approx(100 * 0.01 * 3600 / 200.0)  # 18 % / h
    assert growth_pct_per_hour(t, np.full_like(t, 300.0), 120.0) == pytest.approx(0.0, abs=1e-9)
    assert growth_pct_per_hour(np.array([0.0, 4.0, 8.0]), np.array([1.0, 2.0, 3.0]), 0.0) is None  # 8 s: too short


def test_goal_outcomes():
    goals = [GoalSent(1.0, "unreachable", "goal_pose"), GoalSent(5.0, "reachable", "goal_pose")]
    goals += [GoalSent(10.0, "inside_obstacle", "goal_pose"), GoalSent(20.0, "reachable", "goal_pose")]
    goals += [GoalSent(25.0, "reachable", "goal_pose"), GoalSent(28.0, "grasp", "grasp_pose")]
    status = [_status(0.5 + 0.1 * k, "reached") for k in range(5)]  # the previous goal's "reached" before 1.0
    status += [_status(1.2, "reached", "goal refused: 1.30 m from the shoulder")]
    status += [_status(5.1, "reached", "goal refused: 1.30 m from the shoulder")]  # stale: still the old text
    status += [_status(5.5, "tracking", "goal refused: 1.30 m from the shoulder")]
    status += [_status(7.0, "reached", "goal refused: 1.30 m from the shoulder")]
    status += [_status(12.0, "failed", "", message="failed: goal not reached: no progress for 8 s")]
    status += [_status(21.0, "tracking"), _status(29.0, "holding")]
    logs = [(1.3, "planner", 30, "goal refused: 1.30 m from the shoulder, beyond the reach of 1.05 m")]
    logs += [(5.05, "planner", 30, "goal refused: 1.30 m from the shoulder")]  # in flight: the old goal's
    logs += [(25.5, "planner", 30, "grasp goal refused: the closed loop follows no background plans")]
    logs += [(25.6, "sim", 40, "goal refused: not the planner")]
    out = classify_goals(goals, status, logs, 30.0)
    assert [o["outcome"] for o in out] == ["refused", "reached", "failed", "timed_out", "refused", "timed_out"]
    assert out[0]["reason"].startswith("goal refused: 1.30 m") and out[0]["after_s"] == pytest.approx(0.3)
    assert out[1]["after_s"] == pytest.approx(2.0) and out[2]["reason"].startswith("failed: goal not reached")
    assert out[4]["reason"].startswith("grasp goal refused") and out[3]["after_s"] is None
    assert out[5]["window_s"] == pytest.approx(2.0)


def test_summary_holds_the_required_keys_and_the_worst_node_and_minute():
    t = np.arange(0.0, 180.0, 5.0)
    log = SoakLog(minutes=3.0, duration_s=180.0)
    for node, slope in (("planner", 0.002), ("sim", 0.0)):
        log.resources += [(float(x), node, 100.0 + slope * x, 20, 10) for x in t]
    log.status = [_status(0.1 * k, tick_ms=10.0 if k < 1200 else 40.0) for k in range(1800)]
    log.commands = list(np.round(np.arange(0, 180, 0.1), 3))
    log.contacts = [70.0]
    log.violations = [(100.0, "velocity", "panda_joint1 commanded 0.3 rad")]
    log.goals = [GoalSent(1.0, "reachable", "goal_pose")]
    log.logs = [(3.0, "planner", 40, "tick failed 3 times"), (4.0, "planner", 40, "tick failed 4 times")]
    log.safety = {"commands": 1800}
    res = summarise(log)
    assert all(k in res for k in REQUIRED)
    assert res["minutes"] == 3.0 and res["invariant_violations"] == 1 and res["contacts"] == 1
    assert res["rss_growth_pct_per_hour_max"] == pytest.approx(100 * 0.002 * 3600 / (100 + 0.002 * 36), abs=0.01)
    assert res["nodes"]["sim"]["rss_growth_pct_per_hour"] == 0.0
    assert res["tick_ms_p99_max_minute"] == 40.0 and res["per_minute"][0]["p99"] == 10.0
    assert res["goals_without_outcome"] == 1 and res["missed_periods"] == 0
    assert [m["contacts"] for m in res["per_minute"]] == [0, 1, 0]
    assert res["error_logs"]["planner"][0]["count"] == 2  # the same text but for its numbers
    json.dumps(res)
    text = markdown(res)
    assert "| planner |" in text and "tick failed" in text


def test_each_contact_says_what_the_planner_was_doing_just_before():
    log = SoakLog(minutes=1.0, duration_s=60.0)
    log.contacts = [10.0, 30.0]
    log.doing = [
        (8.5, "plan", "0.01", "tracking: following the background plan"),  # more than a second before: left out
        (9.3, "local", "0.25", "tracking: tracking"),
        (9.8, "local", "", "tracking: backtraced: interpolated step collides"),
        (10.2, "hold", "0.9", "after the contact: left out"),
    ]
    res = summarise(log)
    first, second = res["contacts_context"]
    assert first == {"t": 10.0, "command_sources": ["local"], "p_collision_max": 0.25,
                     "message": "tracking: backtraced: interpolated step collides"}  # fmt: skip
    assert second["command_sources"] == [] and second["p_collision_max"] is None and second["message"] == ""
    assert "| 10.0 | local | 0.250 |" in markdown(res)


def test_group_usage_reads_this_process():
    own = process_usage(os.getpid())
    assert own is not None and own.rss_mb > 1.0 and own.fds >= 3 and own.threads >= 1
    group = group_usage(os.getpgid(0))
    assert group is not None and group.processes >= 1 and group.rss_mb >= own.rss_mb - 1.0
    assert process_usage(2**22 + 12345) is None


# ------------------------------------------------------------------------------------------------ a real run
@pytest.mark.ros
@pytest.mark.slow
@pytest.mark.timeout(300)
def test_short_soak_writes_a_complete_report(tmp_path):
    from latent_planner_ros.bench.soak import main

    code = main(["--minutes", "0.4", "--seed", "1", "--out", str(tmp_path)])
    res = json.loads((tmp_path / "soak.json").read_text())
    assert all(k in res for k in REQUIRED), sorted(res)
    assert res["minutes"] == pytest.approx(0.4, abs=0.02) and res["node_crashes"] == 0
    assert res["safety"]["commands"] > 50 and res["invariant_violations"] == 0
    assert res["goals"]["sent"] >= 2 and res["goals"]["refused_without_reason"] == 0
    assert set(res["nodes"]) == set(res["nodes_run"]) and all(n["samples"] >= 3 for n in res["nodes"].values())
    assert res["events"]["scenario"] == 2 and res["events"]["camera_dropout"] >= 1 and res["events"]["joint_pause"] >= 1
    assert res["relayed"]["clouds"] > 0 and res["relayed"]["joint_states"] > 1000
    assert res["event_errors"] == [], res["event_errors"]
    for name in ("soak.md", "soak_resources.png", "soak_ticks.png", "soak_goals.png", "soak_events.json"):
        assert (tmp_path / name).stat().st_size > 0
    assert code == (0 if res["contacts"] == 0 else 1)


def test_soak_planner_parameters_reach_the_planner_and_unknown_names_are_refused(capsys):
    from latent_planner_ros.bench.soak import main, plan_soak

    plan = plan_soak("geometric", 0, 1.0, ["plan_process=false", "closed_loop.goal_lead_s=0.5"])
    assert {"plan_process:=false", "closed_loop.goal_lead_s:=0.5"} <= set(plan.params["planner"])
    with pytest.raises(SystemExit):
        main(["--out", "/tmp/unused", "--planner-set", "closed_loop.no_such_thing=1"])
    assert "not a planner parameter: closed_loop.no_such_thing" in capsys.readouterr().err

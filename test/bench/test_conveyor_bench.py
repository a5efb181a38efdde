"""bench conveyor without processes: trial randomisation, aggregation over trials, the report table."""

from __future__ import annotations

import numpy as np
import pytest

from latent_planner_ros.bench.conveyor import (
    SPEED_RANGE,
    TARGET_HALF_RANGE,
    aggregate,
    markdown,
    trial_indices,
    trial_settings,
)
from latent_planner_ros.evaluation.stats import wilson_ci95
from sim_bridge.scenario_files import load_scenario, parse_overrides


def test_trial_settings_are_reproducible_and_load_as_scenarios():
    a = [trial_settings(np.random.default_rng(7), 7, i) for i in range(1)]
    rng = np.random.default_rng(7)
    b = [trial_settings(rng, 7, i) for i in range(5)]
    assert a[0] == b[0]
    for seed, overrides, drawn in b:
        assert SPEED_RANGE[0] <= abs(drawn["speed"]) <= SPEED_RANGE[1]
        assert TARGET_HALF_RANGE[0] <= drawn["target_half_extent"] <= TARGET_HALF_RANGE[1]
        scenario = load_scenario("conveyor", seed=seed, overrides=parse_overrides(overrides))
        assert scenario.object("target").half_extents[0] == pytest.approx(drawn["target_half_extent"], abs=1e-4)
    assert len({s for s, _, _ in b}) == 5
    fast = [trial_settings(np.random.default_rng(7), 7, i, max_speed=0.15)[2]["speed"] for i in range(1)]
    assert SPEED_RANGE[0] <= abs(fast[0]) <= 0.15 and abs(fast[0]) != abs(a[0][2]["speed"])


def test_max_belt_speed_out_of_range_is_refused(tmp_path, capsys):
    from latent_planner_ros.bench.conveyor import main

    with pytest.raises(SystemExit):
        main(["--out", str(tmp_path), "--max-belt-speed", "2.0"])
    assert "--max-belt-speed must lie in" in capsys.readouterr().err


def _row(success: bool, collided: bool = False, reach: float | None = 4.0) -> dict:
    return {
        "seed": 1,
        "drawn": {"speed": 0.05, "mode": "wrap", "target_half_extent": 0.025},
        "success": success,
        "reached": reach is not None,
        "tracked": success or collided,
        "collided": collided,
        "collisions": int(collided),
        "missed_ticks": 2,
        "time_to_reach_s": reach,
        "tracking_fraction": 0.8,
        "min_obstacle_distance_m": 0.04,
        "tick_ms_p99": 90.0,
    }


def test_aggregate_counts_successes_collisions_and_pools_ticks():
    rows = [_row(True), _row(True), _row(False, collided=True), _row(False, reach=None)]
    ticks = [np.full(10, 40.0), np.full(10, 60.0), np.zeros(0), np.array([500.0])]
    res = aggregate(rows, ticks)
    assert res["trials"] == 4 and res["successes"] == 2 and res["success"] == 0.5
    assert res["success_ci95"] == pytest.approx(list(wilson_ci95(2, 4)))
    assert res["collisions"] == 1 and res["missed_ticks"] == 8 and res["reached"] == 3
    assert res["tick_ms_p50"] == pytest.approx(60.0) and res["tick_ms_max"] == 500.0  # 21 ticks pooled
    res.update(
        per_trial=rows,
        trial_duration_s=15.0,
        backend="geometric",
        nodes=["sim", "planner"],
        real_time_factor=1.0,
        rule={"pos_tol_m": 0.03, "ori_tol_deg": 20.0, "hold_s": 2.0},
    )
    text = markdown(res)
    assert "2/4 = 0.500" in text and text.count("\n| ") >= 4 + 8


def test_wilson_interval():
    lo, hi = wilson_ci95(28, 30)
    assert lo == pytest.approx(0.787, abs=0.002) and hi == pytest.approx(0.982, abs=0.002)
    assert wilson_ci95(0, 0) == (0.0, 1.0)


def test_only_picks_trials_of_the_sequence_and_refuses_bad_lists():
    assert trial_indices(None, 3) == [0, 1, 2]
    assert trial_indices("44,6", 100) == [44, 6]
    for bad in ("a,b", "3,3", "-1", ""):
        with pytest.raises(ValueError, match="--only"):
            trial_indices(bad, 10)


def test_bad_only_or_planner_set_stop_before_any_process_starts(tmp_path, capsys):
    from latent_planner_ros.bench.conveyor import main

    with pytest.raises(SystemExit):
        main(["--out", str(tmp_path), "--only", "1,1"])
    assert "distinct" in capsys.readouterr().err
    assert main(["--out", str(tmp_path), "--backend", "geometric", "--planner-set", "goal_lead_s"]) == 2
    assert "NAME=VALUE" in capsys.readouterr().err
    with pytest.raises(SystemExit):  # a name the planner does not have would be dropped by the node: refused here
        main(["--out", str(tmp_path), "--planner-set", "closed_loop.no_such=1.0"])
    assert "not a planner parameter: closed_loop.no_such" in capsys.readouterr().err

"""bench faults writes faults.json with the headline figures, faults.md and its plots."""

from __future__ import annotations

import json

import pytest

from latent_planner_ros.bench import faults


def _results() -> dict:
    case = {"group": "scene", "duration_s": 3.0, "notes": ["a note"], "violations": 0}
    stats = {
        "tick_ms_p50": 10.0,
        "tick_ms_p99": 30.0,
        "tick_ms_max": 31.0,
        "commands_per_s": 9.5,
        "missed_periods": 2,
        "command_gap_max_s": 0.2,
    }
    return {
        "cases": 2,
        "survived": 1,
        "failed": ["camera_silent"],
        "invariant_violations": 0,
        "safety": {"command_period_s": 0.1, "slack_rad": 0.02},
        "groups": [
            {"name": "scene", "backend": "learned", "nodes": ["planner"], "notes": [], "startup_s": 4.0, "wall_s": 9.0}
        ],
        "load": {
            "cloud_points": 100000,
            "cloud_rate_hz": 30.0,
            "backend": "learned",
            "baseline": stats,
            "loaded": stats,
        },
        "per_case": [
            {**case, "name": "cloud_nan_points", "survived": True, "checks": {"no crash": True}},
            {**case, "name": "camera_silent", "survived": False, "checks": {"arm holds": False}},
        ],
    }


def test_markdown_and_figures_show_cases_and_load(tmp_path):
    res = _results()
    md = faults.markdown(res)
    assert "FAILED: arm holds" in md and "| under load | 10.0 | 30.0 |" in md and "**0**" in md
    figs = faults.figures(res, {"normal camera": [5.0, 7.0], "under load": [9.0, 30.0]})
    assert set(figs) == {"ticks", "cases"}


@pytest.mark.ros
@pytest.mark.slow
def test_bench_faults_startup_group_writes_its_report(tmp_path):
    assert faults.main(["--out", str(tmp_path), "--groups", "startup"]) == 0
    res = json.loads((tmp_path / "faults.json").read_text())
    assert res["cases"] >= 10 and res["failed"] == [] and res["invariant_violations"] == 0
    assert res["survived"] == res["cases"] and res["load"] is None
    assert (tmp_path / "faults.md").is_file() and (tmp_path / "faults_cases.png").is_file()

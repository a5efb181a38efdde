"""`bench background`: a short run writes its report, with the three runs and their ratios."""

import json

import pytest

from latent_planner_ros.bench.background import main, summarise


def test_the_ratios_are_to_the_run_without_background_plans():
    raw = {
        "none": {"step_ms": [10.0] * 99 + [20.0], "plans": 0},
        "thread": {"step_ms": [10.0] * 90 + [80.0] * 10, "plans": 5},
        "process": {"step_ms": [10.0] * 99 + [20.0], "plans": 5},
    }
    res = summarise(raw)
    assert res["ticks"] == 100 and res["modes"]["none"]["p99_vs_none"] == 1.0
    assert res["modes"]["thread"]["p99_ms"] == 80.0 and res["modes"]["thread"]["p99_vs_none"] > 4.0


@pytest.mark.slow
def test_a_short_run_writes_the_report(tmp_path):
    assert main(["--out", str(tmp_path), "--ticks", "30"]) == 0
    res = json.loads((tmp_path / "background.json").read_text())
    assert set(res["modes"]) == {"none", "thread", "process"}
    assert all(len(res["raw"][m]) == 30 for m in res["modes"])
    assert res["modes"]["process"]["plans"] >= 1 and res["modes"]["thread"]["plans"] >= 1
    assert (tmp_path / "background_steps.png").stat().st_size > 0
    assert "p99 vs none" in (tmp_path / "background.md").read_text()

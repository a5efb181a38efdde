"""`bench planner` writes its documented figures (a small run)."""

import json

import pytest

from latent_planner_ros.bench.planner import main as bench_planner
from latent_planner_ros.bench.planner import wilson_ci95


@pytest.mark.slow
def test_bench_planner_writes_its_json(tmp_path):
    assert bench_planner(["--out", str(tmp_path), "--problems", "2", "--ticks", "5", "--backend", "geometric"]) == 0
    data = json.loads((tmp_path / "planner.json").read_text())
    for key in ("tick_ms_p50", "tick_ms_p99", "open_loop_ms_median"):
        assert data[key] > 0, key
    assert set(data["free"]) >= {"success", "success_ci95", "collisions"}
    assert (tmp_path / "planner_times.png").exists()


def test_bench_planner_refuses_a_missing_collision_checkpoint(tmp_path):
    missing = str(tmp_path / "nope")
    with pytest.raises(SystemExit, match="bench planner"):
        bench_planner(["--out", str(tmp_path), "--problems", "1", "--collision-checkpoint", missing])
    assert not (tmp_path / "planner.json").exists()


def test_wilson_interval():
    lo, hi = wilson_ci95(28, 30)
    assert lo == pytest.approx(0.787, abs=2e-3) and hi == pytest.approx(0.982, abs=2e-3)
    assert wilson_ci95(0, 0) == (0.0, 1.0)

"""`bench sim` writes its JSON, markdown and pictures (short settings)."""

from __future__ import annotations

import json

from latent_planner_ros.bench.sim import main


def test_bench_sim_writes_report(tmp_path):
    assert main(["--out", str(tmp_path), "--seconds", "1", "--paths", "1", "--scenarios", "empty"]) == 0
    results = json.loads((tmp_path / "sim.json").read_text())
    assert results["real_time_factor"] > 0 and results["cloud_points_median"] > 1000
    assert results["tracking_error_mm_max"] < 1.0 and results["tracking_max_speed_ratio"] <= 1.0
    md = (tmp_path / "sim.md").read_text()
    assert "real-time factor" in md and "sim_views.png" in md
    assert {p.name for p in tmp_path.glob("*.png")} == {"sim_views.png", "sim_cloud.png", "sim_tracking.png"}

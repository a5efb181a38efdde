"""`bench fuzz` on one adapter boundary: the report counts what ran and says no node callback did."""

import json

from latent_planner_ros.bench.fuzz import main as bench_fuzz


def test_a_run_of_one_adapter_reports_what_ran(tmp_path):
    assert bench_fuzz(["--examples", "20", "--only", "joint_state_to_q", "--out", str(tmp_path)]) == 0
    data = json.loads((tmp_path / "fuzz.json").read_text())
    assert list(data["boundaries"]) == ["joint_state_to_q"] and data["boundaries"]["joint_state_to_q"]["inputs"] == 20
    assert data["adapters_run"] == 1 and data["node_callbacks_run"] == 0
    md = (tmp_path / "fuzz.md").read_text()
    assert "20 generated inputs requested per adapter (1 run), no node callback run" in md

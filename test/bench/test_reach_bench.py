"""`bench reach` through the real node suite, on one tabletop scene: both planners plan and the sim executes."""

from __future__ import annotations

import json
import os
import random
import subprocess
import sys
from pathlib import Path

import pytest

from latent_planner_ros.bench.reach import markdown, parse_scenarios

REPO = Path(__file__).resolve().parents[2]


def test_scenarios_parse_with_seed_zero_by_default():
    assert parse_scenarios("tabletop:3, shelf") == [("tabletop", 3), ("shelf", 0)]
    with pytest.raises(ValueError):
        parse_scenarios("tabletop:x")


@pytest.mark.ros
@pytest.mark.slow
@pytest.mark.timeout(200)
def test_one_tabletop_scene_is_planned_by_both_planners_and_executed(tmp_path):
    domain = random.SystemRandom().randint(101, 200)
    env = dict(os.environ, PYTHONUNBUFFERED="1", MUJOCO_GL=os.environ.get("MUJOCO_GL", "osmesa"))
    cmd = [sys.executable, "-m", "latent_planner_ros", "bench", "reach", "--out", str(tmp_path)]
    cmd += ["--scenarios", "tabletop:0", "--domain-id", str(domain)]
    proc = subprocess.run(cmd, cwd=REPO, env=env, capture_output=True, text=True, timeout=180)
    assert proc.returncode == 0, proc.stderr[-3000:]
    res = json.loads((tmp_path / "reach.json").read_text())
    assert [r["planner"] for r in res["runs"]] == ["planner", "ompl_planner"]
    for run in res["runs"]:
        assert run["planned"], run
        assert run["final_pos_err_m"] is not None and run["min_distance_m"] is not None
        assert run["plan_s"] > 0 and run["tcp_path_m"] > 0 and run["contacts"] >= 0
    assert set(res["planners"]) == {"planner", "ompl_planner"}
    assert (tmp_path / "reach.md").read_text().startswith(markdown(res).splitlines()[0])
    assert (tmp_path / "reach_runs.png").stat().st_size > 10_000

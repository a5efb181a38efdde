"""`bench robot` writes the documented figures."""

import json

from latent_planner_ros.bench.robot import main


def test_bench_robot_writes_its_json(tmp_path):
    assert main(["--out", str(tmp_path), "--configs", "300", "--sampler-states", "2000"]) == 0
    data = json.loads((tmp_path / "robot.json").read_text())
    assert data["fk_max_pos_err_m"] < 1e-5 and data["fk_max_rot_err_rad"] < 1e-5
    assert data["sampler_states_per_s"] > 0
    assert data["_meta"]["command"].startswith("python -m latent_planner_ros bench robot")
    assert (tmp_path / "robot_fk_error.png").stat().st_size > 1000

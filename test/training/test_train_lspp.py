"""train lspp: a tiny run learns, writes best/last with metadata, and resumes."""

import json

from latent_planner_ros.models.cylinder_classifier import load_classifier
from latent_planner_ros.training.train_lspp import main


def test_a_tiny_run_learns_and_resumes(tmp_path):
    data, run = str(tmp_path / "data"), str(tmp_path / "run")
    common = ["--samples", "2000", "--val-samples", "400", "--data", data, "--out", run,
              "--hidden", "64", "--layers", "2", "--eval-every", "100", "--threads", "1"]  # fmt: skip
    assert main(["--iterations", "200", *common]) == 0
    history = json.loads((tmp_path / "run" / "history.json").read_text())
    assert [h["iteration"] for h in history] == [100, 200]
    assert (tmp_path / "run" / "training.png").is_file()
    assert history[-1]["val_auroc"] > 0.65  # above chance (0.5) after 200 steps of a small net
    model, meta = load_classifier(tmp_path / "run" / "best")
    assert meta["training"]["command"].startswith("python -m latent_planner_ros train lspp")
    assert meta["vae"]["name"] == "vae_kinematic" and len(meta["vae"]["sha256"]) == 64
    assert main(["--iterations", "300", "--resume", *common]) == 0
    history = json.loads((tmp_path / "run" / "history.json").read_text())
    assert [h["iteration"] for h in history] == [100, 200, 300]

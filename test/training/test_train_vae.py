"""A short VAE training run lowers the loss and round-trips through save / load / resume."""

import json

import numpy as np
import torch

from latent_planner_ros.models.vae_io import load_vae
from latent_planner_ros.training.train_vae import VaeTrainer, main
from latent_planner_ros.training.vae_train_config import TrainVaeConfig

TINY = dict(hidden=64, layers=2, pool=4000, refresh=16, heldout=300, eval_every=100, eval_samples=300, batch=128)


def test_short_run_lowers_the_reconstruction_error(tmp_path):
    trainer = VaeTrainer(TrainVaeConfig(**TINY, lr=2e-3), tmp_path, torch.device("cpu"))
    trainer.init_normalisation()
    mse = [trainer.step(tau=1e-3, lr=2e-3)["mse"] for _ in range(300)]
    assert np.mean(mse[-30:]) < 0.5 * np.mean(mse[:30])


def test_cli_run_saves_and_resumes(tmp_path):
    flags = [f"--{k.replace('_', '-')}={v}" for k, v in TINY.items()]
    assert main(["--iterations", "100", "--out", str(tmp_path), *flags]) == 0
    state = json.loads((tmp_path / "last.json").read_text())
    assert state["iteration"] == 100 and len(state["history"]) == 1
    model, meta = load_vae(tmp_path / "best")
    assert meta["training"]["iterations"] == 100
    assert "consistency_median_mm" in meta["metrics"]
    before = {k: v.clone() for k, v in model.state_dict().items()}

    assert main(["--iterations", "200", "--resume", "--out", str(tmp_path), *flags]) == 0
    state = json.loads((tmp_path / "last.json").read_text())
    assert state["iteration"] == 200 and [h["iteration"] for h in state["history"]] == [100, 200]
    resumed = VaeTrainer(TrainVaeConfig(**TINY), tmp_path, torch.device("cpu"))
    resumed.resume()
    assert resumed.iteration == 200
    changed = any(not torch.equal(before[k], v) for k, v in resumed.model.state_dict().items() if k in before)
    assert changed  # the resumed run kept training from the saved weights

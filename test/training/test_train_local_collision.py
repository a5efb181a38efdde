"""Training the local collision predictor: a tiny run lowers the loss, saves best/last, resumes; bad data is named."""

from __future__ import annotations

import json

import pytest

from latent_planner_ros.data.dataset import DatasetConfig, generate_dataset
from latent_planner_ros.data.queries import QuerySamplerConfig
from latent_planner_ros.models.checkpoint import load_checkpoint
from latent_planner_ros.models.local_collision_io import KIND, load_local_collision
from latent_planner_ros.training.train_local_collision import main

TINY = DatasetConfig(
    scenes_per_shard=3, pool=1500, pool_refresh=50, queries=QuerySamplerConfig(n_uniform=24, n_near=40, candidates=600)
)


@pytest.fixture(scope="module")
def workspace(tmp_path_factory):
    root = tmp_path_factory.mktemp("local_collision")
    generate_dataset(root / "train", 3, seed=0, config=TINY, progress=False)
    generate_dataset(root / "val", 3, split="val", seed=7, config=TINY, progress=False)
    return root


def _argv(root, out, *extra):
    return ["--data", str(root / "train"), "--val", str(root / "val"), "--val-unseen", str(root / "none"),
            "--out", str(out), "--scenes", "2", "--queries", "16", "--workers", "1", "--threads", "1",
            "--k", "4", "--hidden", "16", *extra]  # fmt: skip


@pytest.mark.slow
def test_a_tiny_run_lowers_the_loss_saves_and_resumes(workspace):
    out = workspace / "run"
    assert main(_argv(workspace, out, "--iterations", "60", "--eval-every", "20", "--lr", "3e-3")) == 0
    _, last = load_checkpoint(out / "last")
    losses = [h["train_loss"] for h in last["history"]]
    assert last["iteration"] == 60 and len(losses) == 3
    assert losses[-1] < losses[0]
    net, best = load_local_collision(out / "best")
    assert best["kind"] == KIND and net.config.k == 4 and "train local-collision" in best["training"]["command"]
    assert 0.0 <= best["metrics"]["val_auroc_near"] <= 1.0
    assert (workspace / "train" / "local_clouds_0.npz").exists()  # the rendered clouds are cached
    assert main(_argv(workspace, out, "--iterations", "70", "--eval-every", "10", "--resume")) == 0
    _, resumed = load_checkpoint(out / "last")
    assert resumed["iteration"] == 70 and len(resumed["history"]) == 4
    json.dumps(resumed["history"])  # plain JSON


def test_a_missing_dataset_is_named(workspace, capsys):
    with pytest.raises(SystemExit, match="no training shards in"):
        main(_argv(workspace, workspace / "x", "--iterations", "1") + ["--data", str(workspace / "nothing")])

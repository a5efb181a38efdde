"""Collision training: a tiny run lowers the loss; checkpoints save, resume and load."""

import json

import numpy as np
import pytest
import torch

from latent_planner_ros.data.camera import CameraConfig
from latent_planner_ros.data.dataset import CollisionData, DatasetConfig, generate_dataset
from latent_planner_ros.data.queries import QuerySamplerConfig
from latent_planner_ros.models.collision_io import load_collision_net
from latent_planner_ros.models.collision_net_config import CollisionNetConfig
from latent_planner_ros.models.collision_predictor import CollisionPredictor
from latent_planner_ros.models.scene_encoder import SceneEncoderConfig
from latent_planner_ros.models.vae import RobotStateVAE
from latent_planner_ros.models.vae_config import VaeConfig
from latent_planner_ros.models.vae_io import save_vae
from latent_planner_ros.training.train_collision import main
from latent_planner_ros.training.train_collision_config import TrainCollisionConfig
from latent_planner_ros.training.train_collision_trainer import CollisionTrainer, EvalSet

TINY = DatasetConfig(
    scenes_per_shard=2, pool=1500, pool_refresh=50, queries=QuerySamplerConfig(n_uniform=24, n_near=40, candidates=600)
)
SMALL_NET = CollisionNetConfig(
    encoder=SceneEncoderConfig(voxel_size=0.1, point_hidden=8, point_features=16, conv_channels=(16, 16)), hidden=(64,)
)


@pytest.fixture(scope="module")
def workspace(tmp_path_factory):
    root = tmp_path_factory.mktemp("collision")
    generate_dataset(root / "train", 2, seed=0, config=TINY, progress=False)
    for name, family in (("val_seen", "train"), ("val_unseen", "heldout")):
        cfg = DatasetConfig(family=family, scenes_per_shard=5, pool=1500, queries=TINY.queries)
        generate_dataset(root / name, 5, split=name, seed=7, config=cfg, progress=False)
    vae = RobotStateVAE(VaeConfig(hidden=16, layers=1))
    save_vae(root / "vae", vae, {})
    return root


@pytest.mark.slow
def test_a_tiny_run_lowers_the_loss(workspace):
    torch.manual_seed(0)
    cfg = TrainCollisionConfig(
        data=str(workspace / "train"), scenes_per_step=2, queries_per_scene=32, hard_fraction=0.25, threads=1
    )
    data = CollisionData.load(workspace / "train")
    fixed = EvalSet(data, seed=1, camera=CameraConfig())
    vae = RobotStateVAE(VaeConfig(hidden=16, layers=1)).eval()
    trainer = CollisionTrainer(cfg, SMALL_NET, vae, data, {}, workspace / "run_a", torch.device("cpu"))
    before = trainer.evaluate_set(fixed)["loss"]
    for _ in range(60):
        trainer.step(3e-3)
    after = trainer.evaluate_set(fixed)["loss"]
    assert after < 0.8 * before
    # an evaluation set is scored against its own labels, not the training data's
    flipped = CollisionData(data.scenes, data.q, data.scene, ~data.link_labels, data.near, [])
    flipped_set = EvalSet(flipped, seed=1, camera=CameraConfig())
    assert trainer.evaluate_set(flipped_set)["loss"] > 2 * after


@pytest.mark.slow
def test_cli_run_saves_resumes_and_loads(workspace):
    out = workspace / "run_b"
    common = ["--out", str(out), "--vae", str(workspace / "vae"), "--data", str(workspace / "train"),
              "--val-dir", str(workspace), "--val-scenes", "1", "--scenes-per-step", "2", "--queries-per-scene", "16",
              "--eval-every", "3", "--threads", "1"]  # fmt: skip
    assert main(["--iterations", "3", *common]) == 0
    state = json.loads((out / "last.json").read_text())
    assert state["iteration"] == 3 and len(state["history"]) == 1
    assert main(["--iterations", "6", "--resume", *common]) == 0
    state = json.loads((out / "last.json").read_text())
    assert state["iteration"] == 6 and [h["iteration"] for h in state["history"]] == [3, 6]
    net, meta = load_collision_net(out / "best")
    assert meta["vae"]["sha256"] and "train collision" in meta["training"]["command"]
    assert "val_unseen_auroc_near" in meta["metrics"]
    pred = CollisionPredictor.load(out / "best")  # finds the VAE recorded in the metadata
    emb = pred.encode(torch.rand(100, 3))
    assert pred.p_collision(emb, torch.zeros(2, 7)).shape == (2,)


def test_missing_data_or_vae_is_a_clear_error(tmp_path, workspace, capsys):
    assert main(["--iterations", "1", "--out", str(tmp_path), "--vae", str(tmp_path / "none")]) == 2
    assert "VAE" in capsys.readouterr().err
    args = [
        "--iterations",
        "1",
        "--out",
        str(tmp_path),
        "--vae",
        str(workspace / "vae"),
        "--data",
        str(tmp_path / "empty"),
    ]
    assert main(args) == 2
    assert "--generate" in capsys.readouterr().err


def test_cli_grow_writes_the_network_over_a_larger_box_with_both_scores(workspace, tmp_path, capsys):
    from latent_planner_ros.models.collision_io import file_sha256, save_collision_net
    from latent_planner_ros.models.collision_net import CollisionNet

    torch.manual_seed(0)
    parent = save_collision_net(
        tmp_path / "parent",
        CollisionNet(SMALL_NET),
        {"vae": {"sha256": file_sha256(workspace / "vae.safetensors")}, "training": {"command": "train it"}},
    )
    common = ["--vae", str(workspace / "vae"), "--val-dir", str(workspace), "--val-scenes", "2", "--threads", "1"]
    out, stem = tmp_path / "grown", str(parent.with_suffix(""))
    assert main(["--grow", stem, "--box-max", "1.0", "0.6", "1.15", "--out", str(out), *common]) == 0
    net, meta = load_collision_net(out / "best")
    assert net.config.encoder.bounds_max == (1.0, 0.6, 1.15) and meta["grid"]["shape"] == [10, 12, 12]
    assert meta["box"]["parent_bounds_max"] == list(SMALL_NET.encoder.bounds_max)
    assert meta["box"]["parent_sha256"] == file_sha256(parent)
    assert "--grow" in meta["box"]["command"] and meta["training"]["command"] == "train it"
    assert 0.0 <= meta["metrics"]["val_unseen_auroc_near"] <= 1.0 and "val_seen_loss" in meta["box"]["parent_metrics"]
    # a box smaller than the network's, a missing checkpoint, another VAE: clear errors, nothing written
    smaller = ["--box-max", "1.0", "0.6", "0.45", "--out", str(tmp_path / "small")]
    assert main(["--grow", stem, *smaller, *common]) == 2
    assert "contain" in capsys.readouterr().err and not (tmp_path / "small").exists()
    assert main(["--grow", str(tmp_path / "none"), "--box-max", "1.0", "0.6", "1.15", "--out", str(out), *common]) == 2
    assert "none" in capsys.readouterr().err
    other = RobotStateVAE(VaeConfig(hidden=8, layers=1))
    save_vae(tmp_path / "other_vae", other, {})
    args = ["--grow", stem, "--box-max", "1.0", "0.6", "1.15", "--out", str(out), "--vae", str(tmp_path / "other_vae")]
    assert main([*args, "--val-dir", str(workspace), "--threads", "1"]) == 2
    assert "another VAE" in capsys.readouterr().err
    assert main(["--grow", stem, "--out", str(out), *common]) == 2  # no new box
    assert "--box-max" in capsys.readouterr().err


@pytest.mark.slow
def test_cli_init_fine_tunes_a_trained_network_over_a_larger_box(workspace, tmp_path, capsys):
    from latent_planner_ros.models.collision_io import save_collision_net
    from latent_planner_ros.models.collision_net import CollisionNet

    torch.manual_seed(0)
    parent = save_collision_net(tmp_path / "parent", CollisionNet(SMALL_NET), {"training": {"command": "train it"}})
    out = tmp_path / "tuned"
    common = ["--vae", str(workspace / "vae"), "--data", str(workspace / "train"), "--val-dir", str(workspace),
              "--val-scenes", "1", "--scenes-per-step", "2", "--queries-per-scene", "16", "--eval-every", "2",
              "--threads", "1", "--out", str(out)]  # fmt: skip
    box = [
        "--box-min",
        "-1.0",
        "-1.0",
        "-0.05",
        "--box-max",
        "1.0",
        "1.0",
        "1.25",
        "--active-margin",
        "2",
        "--floor-m",
        "0.02",
    ]
    assert main(["--iterations", "2", "--init", str(parent.with_suffix("")), *box, *common]) == 0
    net, meta = load_collision_net(out / "best")
    enc = net.config.encoder
    assert enc.bounds_min == (-1.0, -1.0, -0.05) and enc.bounds_max == (1.0, 1.0, 1.25) and enc.active_margin == 2
    assert meta["init"]["parent"] == str(parent.with_suffix("")) and "--init" in meta["training"]["command"]
    off_grid = ["--box-min", "-0.95", "-1.0", "-0.05"]
    assert main(["--iterations", "1", "--init", str(parent.with_suffix("")), *off_grid, *common]) == 2
    assert "voxel grid" in capsys.readouterr().err


def test_generate_refuses_an_unknown_family(tmp_path, capsys):
    assert main(["--generate", "2", "--family", "kitchen", "--data", str(tmp_path / "d")]) == 2
    assert "kitchen" in capsys.readouterr().err and not (tmp_path / "d").exists()


def test_training_clouds_fuse_several_views_each_point_with_its_camera(workspace):
    cfg = TrainCollisionConfig(data=str(workspace / "train"), views=(2, 2), aim_at_objects=1.0, unknown_eye_prob=0.0,
                               scenes_per_step=2, queries_per_scene=16, hard_fraction=0.0, threads=1)  # fmt: skip
    data = CollisionData.load(workspace / "train")
    vae = RobotStateVAE(VaeConfig(hidden=16, layers=1)).eval()
    trainer = CollisionTrainer(cfg, SMALL_NET, vae, data, {}, workspace / "run_views", torch.device("cpu"))
    points, origins = trainer._cloud(0)
    assert points.shape == origins.shape and len(np.unique(origins, axis=0)) == 2
    assert np.isfinite(trainer.step(1e-3)["loss"])

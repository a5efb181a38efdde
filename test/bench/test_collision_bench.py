"""`bench collision` writes its documented figures (a small run with the shipped checkpoint)."""

import json

import pytest

from latent_planner_ros.bench.collision import main as bench_collision


@pytest.mark.slow
def test_bench_collision_writes_its_json(tmp_path):
    out = tmp_path / "out"
    argv = ["--out", str(out), "--scenes", "3", "--queries", "20", "--data-dir", str(tmp_path / "data")]
    assert bench_collision(argv) == 0
    data = json.loads((out / "collision.json").read_text())
    keys = ["auroc_seen", "auroc_unseen", "auroc_near_seen", "auroc_near_unseen", "recall_near_unseen"]
    keys += ["precision_near_unseen", "geometric_auroc_near_unseen", "encode_ms_median", "query_ms_median"]
    for key in keys:
        assert key in data, key
    best = data["recall_at_precision_0.88_near_seen"]  # nan if no threshold reaches precision 0.88
    assert best != best or data["recall_near_seen"] <= best or data["precision_near_seen"] < 0.88
    assert 0.5 < data["auroc_near_seen"] <= 1.0  # the shipped model ranks collisions above free states
    # the shipped network reads the camera origin: the bench also scores it with the origin withheld
    for key in ["auroc_near_unseen_no_origin", "precision_near_unseen_no_origin", "recall_near_unseen_no_origin"]:
        assert 0.0 <= data[key] <= 1.0, key
    # recall split by what the camera saw: the two parts mix back into the near recall at the threshold
    for name in ("seen", "unseen"):
        share, bins = data[f"hidden_fraction_near_{name}"], data[f"recall_by_cloud_gap_near_{name}"]
        assert 0.0 <= share <= 1.0 and 0.0 <= data[f"missed_hidden_share_near_{name}"] <= 1.0
        parts = [(data[f"recall_near_hidden_{name}"], share), (data[f"recall_near_visible_{name}"], 1 - share)]
        mixed = sum(r * w for r, w in parts if w > 0)
        assert abs(mixed - data[f"recall_near_{name}"]) < 1e-9, name
        assert sum(bins["count"]) > 0 and len(bins["recall"]) == len(bins["count"])
    assert (out / "collision_recall_by_cloud_gap.png").exists()
    # collisions outside the network's box (every contact above or beside it) are split off as well
    for name in ("seen", "unseen"):
        share = data[f"outside_box_share_near_{name}"]
        assert 0.0 <= share <= 1.0 and 0.0 <= data[f"auroc_near_in_box_{name}"] <= 1.0
        if share == 0.0:
            assert data[f"recall_near_in_box_{name}"] == data[f"recall_near_{name}"]
            assert data[f"auroc_near_in_box_{name}"] == data[f"auroc_near_{name}"]
    assert list(out.glob("collision_*.png"))


def test_collisions_beyond_the_networks_box_are_found_by_their_contacts():
    from types import SimpleNamespace

    import numpy as np

    from latent_planner_ros.bench.collision_scores import outside_box
    from latent_planner_ros.data.obstacles import Box
    from latent_planner_ros.data.scene import Scene
    from latent_planner_ros.robot.limits import Q_READY
    from latent_planner_ros.robot.panda import load_panda

    hand = load_panda().fk(Q_READY, "panda_hand").translation  # 0.59 m up
    box = Box(tuple(float(x) for x in hand), (0.0, 0.0, 0.0, 1.0), (0.03, 0.03, 0.03))
    far = Q_READY.copy()
    far[0] += 2.5
    data = SimpleNamespace(
        scenes=[Scene(obstacles=(box,))],
        scene=np.zeros(3, dtype=int),
        near=np.array([True, True, False]),
        labels=np.array([True, False, True]),  # the third is not a near query: never split off
        q=np.stack([Q_READY, far, Q_READY]),
    )
    assert outside_box(data, (0.0, -0.6, -0.05), (1.0, 0.6, 0.55)).tolist() == [True, False, False]
    assert outside_box(data, (0.0, -0.6, -0.05), (1.0, 0.6, 1.0)).tolist() == [False, False, False]


@pytest.mark.slow
def test_bench_collision_scores_each_extra_family_on_its_own(tmp_path):
    out = tmp_path / "out"
    argv = ["--out", str(out), "--scenes", "2", "--queries", "20", "--data-dir", str(tmp_path / "data"),
            "--families", "bookshelf_heldout,bin", "--family-scenes", "2"]  # fmt: skip
    assert bench_collision(argv) == 0
    fam = json.loads((out / "collision.json").read_text())["families"]
    assert sorted(fam) == ["bin", "bookshelf_heldout"]
    for scores in fam.values():
        assert scores["scenes"] == 2 and scores["queries"] > 0 and 0.0 <= scores["recall_near"] <= 1.0
    assert "`bookshelf_heldout`" in (out / "collision.md").read_text() and (out / "collision_families.png").exists()


def test_bench_collision_refuses_an_unknown_family(tmp_path, capsys):
    assert bench_collision(["--out", str(tmp_path / "o"), "--families", "kitchen"]) == 2
    assert "kitchen" in capsys.readouterr().out and not (tmp_path / "o").exists()


def test_workcell_scenes_are_scored_on_fused_views_of_their_furniture():
    import numpy as np

    from latent_planner_ros.bench.collision_scores import fused_view
    from latent_planner_ros.data.camera import CameraConfig
    from latent_planner_ros.data.scene_families import generate_family_scene

    scene = generate_family_scene(np.random.default_rng(0), "bin_heldout")
    cloud, origins = fused_view(scene, np.random.default_rng(1), CameraConfig(), 3)
    assert cloud.shape == origins.shape and len(np.unique(origins, axis=0)) == 3


@pytest.mark.slow
def test_bench_collision_scores_a_local_predictor_without_a_box(tmp_path, capsys):
    import torch

    from latent_planner_ros.models.checkpoint import save_checkpoint
    from latent_planner_ros.models.local_collision import LocalCollisionConfig, LocalCollisionNet
    from latent_planner_ros.models.local_collision_io import KIND

    torch.manual_seed(0)
    config = LocalCollisionConfig(k=4, hidden=16)
    stem = tmp_path / "local"
    meta = {"kind": KIND, "architecture": config.to_dict()}
    save_checkpoint(stem, dict(LocalCollisionNet(config).state_dict()), meta)
    out = tmp_path / "out"
    argv = ["--out", str(out), "--scenes", "2", "--queries", "20", "--data-dir", str(tmp_path / "data"),
            "--checkpoint", str(stem), "--families", "cage_heldout", "--family-scenes", "2"]  # fmt: skip
    assert bench_collision(argv) == 0
    data = json.loads((out / "collision.json").read_text())
    assert 0.0 <= data["auroc_near_unseen"] <= 1.0 and data["checkpoint"] == str(stem)
    assert data["families"]["cage_heldout"]["outside_box_share_near"] == 0.0  # it is given the whole reach
    assert 0.0 <= data["auroc_near_unseen_no_origin"] <= 1.0  # it reads camera origins: scored without them too
    assert bench_collision([*argv[:2], "--checkpoint", str(stem), "--vae", str(stem)]) == 2
    assert "reads no VAE" in capsys.readouterr().out

"""Distillation of the collision classifier: the student learns the teacher's logits and ships like a network."""

import dataclasses

import pytest
import torch

from latent_planner_ros.models.collision_io import file_sha256, load_collision_net, shipped_collision_path
from latent_planner_ros.models.collision_net import CollisionNet
from latent_planner_ros.models.collision_predictor import CollisionPredictor
from latent_planner_ros.training.distil_collision import (
    LOGIT_CLAMP,
    agreement,
    distil,
    main,
    parse_args,
    teacher_samples,
)

TINY = ["--scenes", "2", "--val-scenes", "1", "--per-scene", "16", "--batch", "64", "--threads", "1"]


def test_distil_writes_a_loadable_student_with_the_teachers_encoder(tmp_path):
    assert main(["--hidden", "16", "8", "--epochs", "1", "--out", str(tmp_path), *TINY]) == 0
    student, meta = load_collision_net(tmp_path / "best")
    teacher, teacher_meta = load_collision_net(None)
    assert student.config.hidden == (16, 8)
    assert [m.out_features for m in student.classifier if isinstance(m, torch.nn.Linear)] == [16, 8, 1]
    for name, value in teacher.encoder.state_dict().items():
        assert torch.equal(student.encoder.state_dict()[name], value), name
    info = meta["distil"]
    assert info["teacher_sha256"] == file_sha256(shipped_collision_path().with_suffix(".safetensors"))
    assert info["command"].startswith("python -m latent_planner_ros train distil --hidden 16 8")
    assert info["teacher"] == "shipped collision"
    assert info["teacher_training"]["training"] == teacher_meta["training"]
    assert "training" not in meta and meta["vae"] == teacher_meta["vae"]
    for family in ("train", "heldout"):
        assert 0.0 <= info["metrics"][f"val_{family}_agreement"] <= 1.0
    predictor = CollisionPredictor.load(tmp_path / "best")  # finds the teacher's VAE through the metadata
    p = predictor.p_collision(predictor.encode(torch.rand(200, 3).numpy()), torch.zeros(4, 7))
    assert p.shape == (4,) and torch.all((p >= 0) & (p <= 1))


@pytest.mark.parametrize("no_latent", [False, True])
def test_the_student_learns_the_teachers_logits(tmp_path, no_latent):
    flags = ["--no-latent"] if no_latent else []
    args = parse_args(["--hidden", "32", "--epochs", "40", "--out", str(tmp_path), *flags, *TINY])
    torch.set_num_threads(1)
    student, metrics = distil(args)
    assert student.reads_latent is not no_latent
    predictor = CollisionPredictor.load(None)
    x, y = teacher_samples(predictor, student, args.scenes, "train", args.seed, args.per_scene)
    y = y.clamp(-LOGIT_CLAMP, LOGIT_CLAMP)
    untrained = CollisionNet(student.config)
    with torch.no_grad():
        mse = (student.classifier(x).squeeze(-1) - y).pow(2).mean()
        mse0 = (untrained.classifier(x).squeeze(-1) - y).pow(2).mean()
    assert mse < 0.5 * mse0
    assert metrics["train_mse"] < 0.5 * float(mse0)


def test_a_student_without_the_latent_needs_no_vae_encoder_pass(tmp_path, monkeypatch):
    assert main(["--hidden", "16", "--epochs", "1", "--no-latent", "--out", str(tmp_path), *TINY]) == 0
    student, meta = load_collision_net(tmp_path / "best")
    assert meta["architecture"]["latent"] == 0 and not student.reads_latent
    teacher = load_collision_net(None)[0]
    in_features = [m.in_features for m in (student.classifier[0], teacher.classifier[0])]
    assert in_features[1] - in_features[0] == teacher.config.latent  # the same inputs less z
    predictor = CollisionPredictor.load(tmp_path / "best")
    emb = predictor.encode(torch.rand(200, 3).numpy())
    q = torch.rand(5, 7)
    with torch.no_grad():
        z = predictor.vae.encode_q(q)
        p_latent = predictor.p_collision(emb, z)  # q decoded from z, z itself unread
        p_decoded = predictor.p_collision_q(emb, predictor.vae.decode_q(z))

        def no_encoder(*_):
            raise AssertionError("the VAE encoder ran")

        monkeypatch.setattr(predictor.vae, "encode_q", no_encoder)
        p_q = predictor.p_collision_q(emb, q)
    assert p_q.shape == (5,) and torch.all((p_q >= 0) & (p_q <= 1))
    torch.testing.assert_close(p_latent, p_decoded)


def test_agreement_counts_the_unsafe_kind_of_disagreement():
    net = CollisionNet(dataclasses.replace(load_collision_net(None)[0].config, hidden=(4,)))
    with torch.no_grad():
        for m in net.classifier:
            if isinstance(m, torch.nn.Linear):
                m.weight.zero_()
                m.bias.fill_(-5.0)  # the student accepts everything (p ~ 0.007)
    x = torch.zeros(4, net.n_links, 224)
    teacher = torch.full((4, net.n_links), -5.0)
    teacher[0, 3] = 2.0  # the teacher refuses the first configuration only
    scores = agreement(net, x, teacher, threshold=0.2)
    assert scores["agreement"] == pytest.approx(0.75)
    assert scores["teacher_refuses_student_accepts"] == pytest.approx(0.25)
    assert scores["teacher_refusal_rate"] == pytest.approx(0.25)


def test_bad_arguments_and_a_missing_teacher_are_refused(tmp_path, capsys):
    with pytest.raises(SystemExit) as e:
        parse_args(["--hidden", "0", "--out", str(tmp_path)])
    assert e.value.code == 2 and "--hidden" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        parse_args(["--hidden", "8", "--out", str(tmp_path), "--epochs", "0"])
    with pytest.raises(SystemExit):
        parse_args(["--hidden", "8", "--out", str(tmp_path), "--family", "kitchen"])
    assert "kitchen" in capsys.readouterr().err
    assert main(["--hidden", "8", "--out", str(tmp_path), "--teacher", str(tmp_path / "nope"), *TINY]) == 2
    assert "train distil" in capsys.readouterr().err
    assert not (tmp_path / "best.safetensors").exists()


def test_distil_learns_from_the_families_it_is_given(tmp_path):
    args = ["--hidden", "8", "--epochs", "1", "--out", str(tmp_path), "--family", "mix", "--val-family", "bin_heldout"]
    assert main([*args, *TINY]) == 0
    _, meta = load_collision_net(tmp_path / "best")
    assert "--family mix" in meta["distil"]["command"]
    assert 0.0 <= meta["distil"]["metrics"]["val_heldout_agreement"] <= 1.0

"""The shipped collision predictors (the network and its distilled planning version) separate clearly colliding
from clearly free states in a fixed scene."""

import numpy as np
import pytest
import torch

from latent_planner_ros.data.camera import look_at
from latent_planner_ros.data.labels import CollisionLabeler, link_poses
from latent_planner_ros.data.obstacles import Box, Cylinder
from latent_planner_ros.data.render import scene_view
from latent_planner_ros.data.scene import Scene
from latent_planner_ros.models.collision_io import (
    DEFAULT_COLLISION,
    PLANNER_COLLISION,
    file_sha256,
    load_collision_net,
    shipped_collision_path,
)
from latent_planner_ros.models.collision_metrics import auroc
from latent_planner_ros.models.collision_predictor import CollisionPredictor
from latent_planner_ros.robot.sampler import FeasibleSampler


@pytest.mark.parametrize("stem", [DEFAULT_COLLISION, PLANNER_COLLISION])
@pytest.mark.parametrize("with_origin", [True, False], ids=["origin known", "origin unknown"])
def test_shipped_predictor_separates_colliding_from_free_states(with_origin, stem):
    torch.set_num_threads(1)
    scene = Scene(
        (
            Box((0.5, 0.15, 0.12), (0.0, 0.0, 0.0, 1.0), (0.08, 0.12, 0.12)),
            Cylinder((0.45, -0.3, 0.15), (0.0, 0.0, 0.0, 1.0), 0.05, 0.15),
        )
    )
    rng = np.random.default_rng(3)
    cloud, eye = scene_view(scene, rng, pose=look_at(np.array([1.6, 0.6, 0.9]), np.array([0.5, 0.0, 0.2])))
    np.testing.assert_allclose(eye, [1.6, 0.6, 0.9], atol=1e-6)
    q = FeasibleSampler(rng).sample(6000)
    labels = CollisionLabeler(scene).label(q).any(axis=1)
    # clearly free: every link origin at least 25 cm from both objects' centres
    origins = link_poses(q)[:, :, :3, 3]
    centres = np.array([[0.5, 0.15, 0.12], [0.45, -0.3, 0.15]])
    far = np.linalg.norm(origins[:, :, None] - centres[None, None], axis=-1).min(axis=(1, 2)) > 0.25
    colliding, free = q[labels], q[~labels & far]
    assert len(colliding) > 50 and len(free) > 200
    predictor = CollisionPredictor.load(shipped_collision_path(stem))
    emb = predictor.encode(cloud, eye if with_origin else None)
    with torch.no_grad():
        p_col = predictor.p_collision_q(emb, torch.as_tensor(colliding, dtype=torch.float32)).numpy()
        p_free = predictor.p_collision_q(emb, torch.as_tensor(free, dtype=torch.float32)).numpy()
    assert np.median(p_col) > 0.7 and np.median(p_free) < 0.1, (np.median(p_col), np.median(p_free))
    scores = np.r_[p_col, p_free]
    assert auroc(scores, np.r_[np.ones(len(p_col)), np.zeros(len(p_free))]) > 0.95


def test_the_planning_predictor_is_the_shipped_network_with_a_distilled_classifier():
    teacher, teacher_meta = load_collision_net(shipped_collision_path(DEFAULT_COLLISION))
    student, meta = load_collision_net(shipped_collision_path(PLANNER_COLLISION))
    assert len(student.config.hidden) == len(teacher.config.hidden)
    assert all(s < t for s, t in zip(student.config.hidden, teacher.config.hidden, strict=True))
    assert teacher.reads_latent and not student.reads_latent  # the hard check needs no VAE encoder pass
    for name, value in teacher.encoder.state_dict().items():  # the scene_encoder node's embeddings fit both
        assert torch.equal(student.encoder.state_dict()[name], value), name
    info = meta["distil"]
    assert info["teacher_sha256"] == file_sha256(shipped_collision_path(DEFAULT_COLLISION).with_suffix(".safetensors"))
    assert meta["vae"]["sha256"] == teacher_meta["vae"]["sha256"]
    for family in ("train", "heldout"):
        assert info["metrics"][f"val_{family}_agreement"] > 0.99
        assert info["metrics"][f"val_{family}_teacher_refuses_student_accepts"] < 0.005

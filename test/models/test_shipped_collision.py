"""The shipped collision predictor separates clearly colliding from clearly free states in a fixed scene."""

import numpy as np
import pytest
import torch

from latent_planner_ros.data.camera import look_at
from latent_planner_ros.data.labels import CollisionLabeler, link_poses
from latent_planner_ros.data.obstacles import Box, Cylinder
from latent_planner_ros.data.render import scene_view
from latent_planner_ros.data.scene import Scene
from latent_planner_ros.models.collision_metrics import auroc
from latent_planner_ros.models.collision_predictor import CollisionPredictor
from latent_planner_ros.robot.sampler import FeasibleSampler


@pytest.mark.parametrize("with_origin", [True, False], ids=["origin known", "origin unknown"])
def test_shipped_predictor_separates_colliding_from_free_states(with_origin):
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
    predictor = CollisionPredictor.load()
    emb = predictor.encode(cloud, eye if with_origin else None)
    with torch.no_grad():
        p_col = predictor.p_collision_q(emb, torch.as_tensor(colliding, dtype=torch.float32)).numpy()
        p_free = predictor.p_collision_q(emb, torch.as_tensor(free, dtype=torch.float32)).numpy()
    assert np.median(p_col) > 0.7 and np.median(p_free) < 0.1, (np.median(p_col), np.median(p_free))
    scores = np.r_[p_col, p_free]
    assert auroc(scores, np.r_[np.ones(len(p_col)), np.zeros(len(p_free))]) > 0.95

"""The learned collision backend: embedding transport, differentiable cost, hard check."""

import numpy as np
import pytest
import torch

from latent_planner_ros.models.collision_net import CollisionNet
from latent_planner_ros.models.collision_net_config import CollisionNetConfig
from latent_planner_ros.models.collision_predictor import CollisionPredictor
from latent_planner_ros.models.scene_encoder import SceneEncoderConfig
from latent_planner_ros.models.vae import RobotStateVAE
from latent_planner_ros.models.vae_config import VaeConfig
from latent_planner_ros.planning.learned_backend import LearnedBackend
from latent_planner_ros.robot.limits import Q_READY
from latent_planner_ros.robot.panda import load_panda
from msg_adapters import cloud_to_embedding, xyz_to_cloud

SMALL = CollisionNetConfig(
    encoder=SceneEncoderConfig(
        voxel_size=0.2, bounds_max=(1.0, 0.6, 0.75), point_hidden=8, point_features=8, conv_channels=(8, 6)
    ),
    hidden=(16,),
)


def _backend(**kwargs) -> LearnedBackend:
    torch.manual_seed(0)
    vae = RobotStateVAE(VaeConfig(hidden=16, layers=1))
    return LearnedBackend(CollisionPredictor(CollisionNet(SMALL), vae), **kwargs)


def test_embedding_message_round_trip_and_refusals(rng):
    backend = _backend()
    cloud = rng.uniform([0.2, -0.4, 0.0], [0.8, 0.4, 0.5], size=(300, 3)).astype(np.float32)
    backend.set_scene(cloud)
    centres, feats = backend.embedding.to_points()
    msg = xyz_to_cloud(centres, features=feats)
    back = backend.embedding_from_points(*cloud_to_embedding(msg))
    torch.testing.assert_close(back.features, backend.embedding.features)
    with pytest.raises(ValueError, match="features"):
        backend.embedding_from_points(*cloud_to_embedding(xyz_to_cloud(centres, features=feats[:, :3])))
    with pytest.raises(ValueError):
        backend.embedding_from_points(*cloud_to_embedding(xyz_to_cloud(centres[:-1], features=feats[:-1])))


def test_cost_is_differentiable_and_matches_the_predictor(rng):
    backend = _backend()
    backend.set_scene(rng.uniform([0.2, -0.4, 0.0], [0.8, 0.4, 0.5], size=(300, 3)))
    z = torch.randn(5, 7, requires_grad=True)
    q = backend.predictor.vae.decode(z).q
    p = backend.p_collision(q, z)
    assert p.shape == (5,) and torch.all((p > 0) & (p < 1))
    p.sum().backward()
    assert z.grad is not None and torch.isfinite(z.grad).all() and z.grad.abs().sum() > 0
    expected = backend.predictor.p_collision(backend.embedding, z.detach())
    torch.testing.assert_close(p.detach(), expected)


def test_hard_check_refuses_observed_points_inside_the_arm_even_if_the_network_does_not():
    backend = _backend(threshold=1.1)  # the network alone never says "collision"
    point = load_panda().fk(Q_READY, "panda_link4").translation  # inside the elbow
    q = np.stack([Q_READY, Q_READY + 0.0])
    backend.set_scene(np.zeros((0, 3)))
    assert not backend.check(q).any()
    backend.set_scene(np.asarray(point, dtype=float).reshape(1, 3))
    assert backend.check(q).all()
    no_geo = _backend(threshold=1.1, geometric_check=False)
    no_geo.set_scene(np.asarray(point, dtype=float).reshape(1, 3))
    assert not no_geo.check(q).any()
    always = _backend(threshold=1e-9, geometric_check=False)
    assert always.check(q).all()


def test_a_cloud_is_encoded_with_its_camera_origin_and_a_non_finite_origin_counts_as_unknown(rng):
    torch.manual_seed(0)
    config = CollisionNetConfig(encoder=SceneEncoderConfig(visibility=True, conv_channels=(8, 6)), hidden=(16,))
    vae = RobotStateVAE(VaeConfig(hidden=16, layers=1))
    backend = LearnedBackend(CollisionPredictor(CollisionNet(config), vae))
    cloud = rng.uniform([0.3, -0.2, 0.0], [0.5, 0.2, 0.3], size=(500, 3)).astype(np.float32)
    backend.set_scene(cloud, np.array([1.6, 0.7, 0.9]))
    seen = backend.embedding.features.clone()
    backend.set_scene(cloud)
    blind = backend.embedding.features.clone()
    backend.set_scene(cloud, np.array([np.nan, 0.0, 1.0]))
    assert not torch.allclose(seen, blind)
    torch.testing.assert_close(backend.embedding.features, blind)


def test_per_point_origins_of_one_camera_equal_its_single_origin_and_two_cameras_differ(rng):
    torch.manual_seed(0)
    config = CollisionNetConfig(encoder=SceneEncoderConfig(visibility=True, conv_channels=(8, 6)), hidden=(16,))
    vae = RobotStateVAE(VaeConfig(hidden=16, layers=1))
    backend = LearnedBackend(CollisionPredictor(CollisionNet(config), vae), max_views=0)  # encode any views
    cloud = rng.uniform([0.3, -0.2, 0.0], [0.5, 0.2, 0.3], size=(500, 3)).astype(np.float32)
    cloud[::50] = np.nan  # dropped with their origins
    cloud[1::50, 2] = 2.0  # above the network's box: cropped with their origins
    eye, other = np.array([1.6, 0.7, 0.9]), np.array([0.4, -1.2, 1.0])
    backend.set_scene(cloud, eye)
    single = backend.embedding.features.clone()
    backend.set_scene(cloud, np.tile(eye, (len(cloud), 1)))
    assert torch.equal(backend.embedding.features, single)
    origins = np.tile(eye, (len(cloud), 1))
    origins[len(cloud) // 2 :] = other
    backend.set_scene(cloud, origins)
    assert not torch.allclose(backend.embedding.features, single)
    with pytest.raises(ValueError, match="origin"):
        backend.set_scene(cloud, origins[:-1])


def test_points_above_the_networks_box_reach_the_hard_check_but_not_the_encoder(rng):
    torch.manual_seed(0)
    encoder = SceneEncoderConfig(visibility=True, conv_channels=(8, 6), bounds_max=(1.0, 0.6, 0.55))
    config = CollisionNetConfig(encoder=encoder, hidden=(16,))
    vae = RobotStateVAE(VaeConfig(hidden=16, layers=1))
    backend = LearnedBackend(CollisionPredictor(CollisionNet(config), vae), threshold=1.1)  # network never refuses
    low = rng.uniform([0.3, -0.2, 0.0], [0.5, 0.2, 0.3], size=(500, 3)).astype(np.float32)
    elbow = load_panda().fk(Q_READY, "panda_link5").translation  # 0.70 m up: above the box (0.55 m)
    assert elbow[2] > config.encoder.bounds_max[2]
    # a shelf between the camera and the box: without the crop it would hide the box's voxels from the camera
    high = np.concatenate([rng.uniform([0.2, -0.3, 0.8], [0.6, 0.3, 0.82], size=(400, 3)), elbow[None]])
    origin = np.array([0.4, 0.0, 1.6])
    backend.set_scene(low, origin)
    alone = backend.embedding.features.clone()
    assert not backend.check(Q_READY[None]).any()
    backend.set_scene(np.concatenate([low, high.astype(np.float32)]), origin)
    torch.testing.assert_close(backend.embedding.features, alone)  # the network's input is its box, as trained
    assert backend.check(Q_READY[None]).all()  # the spheres see the point in the elbow


def test_hard_check_is_network_or_spheres_and_the_network_sees_only_what_the_spheres_left_open(rng):
    backend = LearnedBackend.load()
    cloud = rng.uniform([0.3, -0.3, 0.0], [0.6, 0.3, 0.5], size=(800, 3))
    backend.set_scene(cloud, np.array([1.5, 0.0, 1.0]))
    q = Q_READY + rng.uniform(-1.0, 1.0, size=(200, 7)) * [1.5, 1.0, 1.0, 0.8, 1.5, 1.0, 1.5]
    with torch.no_grad():
        p = backend.predictor.p_collision_q(backend.embedding, torch.as_tensor(q, dtype=torch.float32)).numpy()
    by_net, by_spheres = p >= backend.threshold, backend.geometric.check(q)
    assert by_spheres.any() and (by_net & ~by_spheres).any() and (~by_net & ~by_spheres).any()
    seen = []
    logits = backend.predictor.net.check_logits  # the shipped network reads no latent: the check's fast path
    backend.predictor.net.check_logits = lambda table, poses: seen.append(len(poses)) or logits(table, poses)
    np.testing.assert_array_equal(backend.check(q), by_net | by_spheres)
    assert seen == [int((~by_spheres).sum())]


def test_the_default_backend_loads_the_distilled_planning_predictor_and_a_stem_overrides_it():
    from latent_planner_ros.models.collision_io import DEFAULT_COLLISION, load_collision_net, shipped_collision_path

    planning = LearnedBackend.load()
    expected, _ = load_collision_net(shipped_collision_path("collision_distilled"))
    assert planning.predictor.net.config.hidden == expected.config.hidden
    full = LearnedBackend.load(shipped_collision_path(DEFAULT_COLLISION))
    assert full.predictor.net.config.hidden != planning.predictor.net.config.hidden


def test_p_collision_from_shared_link_frames_equals_the_networks_own_fk(rng):
    backend = LearnedBackend.load()
    assert backend.takes_frames
    backend.set_scene(rng.uniform([0.3, -0.3, 0.0], [0.6, 0.3, 0.5], size=(800, 3)), np.array([1.5, 0.0, 1.0]))
    vae = backend.predictor.vae
    z = torch.randn(8, vae.config.latent, generator=torch.Generator().manual_seed(0), requires_grad=True)
    q = vae.decode_q(z)
    shared = backend.p_collision(q, z, frames=vae.fk(q))
    own = backend.p_collision(q, z)
    torch.testing.assert_close(shared, own)
    (g_shared,) = torch.autograd.grad(shared.sum(), z, retain_graph=True)
    (g_own,) = torch.autograd.grad(own.sum(), z)
    assert g_own.abs().max() > 0
    torch.testing.assert_close(g_shared, g_own)

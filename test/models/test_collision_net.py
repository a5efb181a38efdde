"""Scene encoder and collision network: shapes, embedding transport, gradients, checkpoints."""

import dataclasses

import numpy as np
import pytest
import torch

from latent_planner_ros.data.link_geometry import LABEL_LINKS
from latent_planner_ros.models import trilinear
from latent_planner_ros.models.checkpoint import CheckpointError
from latent_planner_ros.models.collision_io import load_collision_net, load_scene_encoder, save_collision_net
from latent_planner_ros.models.collision_net import CollisionNet
from latent_planner_ros.models.collision_net_config import CollisionNetConfig
from latent_planner_ros.models.collision_predictor import CollisionPredictor
from latent_planner_ros.models.scene_encoder import SceneEmbedding, SceneEncoderConfig, conv3d_by_slices
from latent_planner_ros.models.vae import RobotStateVAE
from latent_planner_ros.models.vae_config import VaeConfig
from latent_planner_ros.robot.limits import Q_READY

SMALL = CollisionNetConfig(
    encoder=SceneEncoderConfig(
        voxel_size=0.2, bounds_max=(1.0, 0.6, 0.75), point_hidden=8, point_features=8, conv_channels=(8, 6)
    ),
    hidden=(16,),
)


def _cloud(rng, n=500):
    return (rng.uniform([0.0, -0.6, 0.0], [1.0, 0.6, 0.4], size=(n, 3))).astype(np.float32)


def _predictor(dtype=torch.float32):
    net = CollisionNet(SMALL).to(dtype)
    vae = RobotStateVAE(VaeConfig(hidden=16, layers=1)).to(dtype)
    return CollisionPredictor(net, vae)


def test_grid_shape_and_bad_bounds():
    assert SceneEncoderConfig().grid_shape == (10, 12, 6)
    with pytest.raises(ValueError, match="whole number"):
        SceneEncoderConfig(voxel_size=0.3)


def test_embedding_survives_transport_as_voxel_points_in_any_order(rng):
    pred = _predictor()
    emb = pred.encode(_cloud(rng))
    assert emb.features.shape == (6, *SMALL.encoder.grid_shape)
    centres, feats = emb.to_points()
    assert centres.shape == (emb.features[0].numel(), 3) and feats.shape == (len(centres), 6)
    perm = rng.permutation(len(centres))
    back = pred.embedding_from_points(centres[perm], feats[perm])
    torch.testing.assert_close(back.features, emb.features)
    with pytest.raises(ValueError, match="grid"):
        pred.embedding_from_points(centres + 0.03, feats)
    with pytest.raises(ValueError, match="voxels"):
        pred.embedding_from_points(centres[1:], feats[1:])


def test_batched_encoding_equals_one_by_one_and_ignores_outside_points(rng):
    net = CollisionNet(SMALL).eval()
    a, b = torch.as_tensor(_cloud(rng)), torch.as_tensor(_cloud(rng, 300))
    outside = torch.tensor([[5.0, 0.0, 0.0], [0.5, 0.0, -1.0]])
    with torch.no_grad():
        both = net.encoder(torch.cat([a, b]), torch.cat([torch.zeros(len(a)), torch.ones(len(b))]).long(), 2)
        torch.testing.assert_close(both[0], net.encoder(a)[0])
        torch.testing.assert_close(both[1], net.encoder(torch.cat([b, outside]))[0])


def test_p_collision_shapes_and_batch_independence(rng):
    pred = _predictor()
    emb = pred.encode(_cloud(rng))
    z = torch.randn(5, 7)
    p = pred.p_collision(emb, z)
    assert p.shape == (5,) and torch.all((p > 0) & (p < 1))
    assert pred.link_logits(emb, z).shape == (5, len(LABEL_LINKS))
    torch.testing.assert_close(pred.p_collision(emb, z[2:3]), p[2:3])
    q = torch.as_tensor(Q_READY, dtype=torch.float32)[None]
    assert pred.p_collision_q(emb, q).shape == (1,)


def test_gradient_wrt_z_matches_finite_differences(rng):
    pred = _predictor(torch.float64)
    emb = pred.encode(_cloud(rng))
    emb = SceneEmbedding(emb.features.double(), emb.config)
    z = torch.randn(3, 7, dtype=torch.float64, requires_grad=True)
    assert torch.autograd.gradcheck(lambda zz: pred.p_collision(emb, zz), (z,), eps=1e-6, atol=1e-6, rtol=1e-4)
    assert torch.autograd.gradcheck(lambda zz: pred.link_logits(emb, zz), (z,), eps=1e-6, atol=1e-6, rtol=1e-4)


def test_a_network_that_does_not_read_z_still_has_gradients_through_the_decoder(rng):
    net = CollisionNet(dataclasses.replace(SMALL, latent=0)).to(torch.float64)
    pred = CollisionPredictor(net, RobotStateVAE(VaeConfig(hidden=16, layers=1)).to(torch.float64))
    assert net.classifier[0].in_features == CollisionNet(SMALL).classifier[0].in_features - 7
    emb = pred.encode(_cloud(rng))
    emb = SceneEmbedding(emb.features.double(), emb.config)
    z = torch.randn(3, 7, dtype=torch.float64, requires_grad=True)
    assert torch.autograd.gradcheck(lambda zz: pred.p_collision(emb, zz), (z,), eps=1e-6, atol=1e-6, rtol=1e-4)
    assert pred.latent_of(torch.zeros(3, 7)).shape == (3, 0)
    with pytest.raises(ValueError, match="latent"):
        CollisionNetConfig(latent=-1)


def test_checkpoint_round_trip_and_clear_errors(tmp_path, rng):
    net = CollisionNet(SMALL)
    save_collision_net(tmp_path / "c", net, {"metrics": {"auroc": 0.5}})
    back, meta = load_collision_net(tmp_path / "c")
    assert meta["grid"]["voxel_size"] == 0.2 and meta["links"] == list(LABEL_LINKS)
    cloud = torch.as_tensor(_cloud(rng))
    with torch.no_grad():
        torch.testing.assert_close(back.encoder(cloud), net.eval().encoder(cloud))
    enc = load_scene_encoder(tmp_path / "c")
    with torch.no_grad():
        torch.testing.assert_close(enc.encode(cloud).features, net.encoder.encode(cloud).features)
    with pytest.raises(CheckpointError, match="missing"):
        load_collision_net(tmp_path / "nope")
    (tmp_path / "c.safetensors").write_bytes(b"\x00garbage")
    with pytest.raises(CheckpointError, match="corrupt"):
        load_collision_net(tmp_path / "c")
    save_collision_net(tmp_path / "d", net, {})
    (tmp_path / "d.json").write_text("{not json")
    with pytest.raises(CheckpointError, match="JSON"):
        load_collision_net(tmp_path / "d")


def test_inference_encoding_equals_the_autograd_path(rng):
    net = CollisionNet(SMALL).eval()
    cloud = torch.as_tensor(_cloud(rng))
    with torch.no_grad():
        fast = net.encoder(cloud)
    torch.testing.assert_close(fast, net.encoder(cloud).detach(), rtol=1e-5, atol=1e-6)


@pytest.mark.parametrize("bias", [True, False])
def test_conv3d_by_slices_equals_conv3d(rng, bias):
    conv = torch.nn.Conv3d(5, 4, 3, padding=1, bias=bias)
    x = torch.as_tensor(rng.normal(size=(2, 5, 4, 6, 3)), dtype=torch.float32)
    with torch.no_grad():
        torch.testing.assert_close(conv3d_by_slices(x, conv), conv(x), rtol=1e-5, atol=1e-5)
    other = torch.nn.Conv3d(5, 4, 1)  # not a 3x3x3 same-size convolution: left to conv3d
    torch.testing.assert_close(conv3d_by_slices(x, other), other(x))


def test_check_logits_equal_link_logits_for_a_network_that_does_not_read_z(rng):
    torch.manual_seed(1)
    net = CollisionNet(dataclasses.replace(SMALL, latent=0)).eval()
    grid = net.encoder.encode(_cloud(rng)).features
    q = torch.as_tensor(Q_READY + rng.uniform(-1.5, 1.5, size=(40, 7)), dtype=torch.float32)
    with torch.no_grad():
        expected = net.link_logits(grid[None], q[None], None)[0]
    poses = net.fk.frames_np(q.double().numpy())  # (M, L, 4, 4) of LABEL_LINKS
    got = net.check_logits(trilinear.channels_last(grid), poses)
    assert got.shape == (40, len(LABEL_LINKS))
    torch.testing.assert_close(got, expected, atol=1e-4, rtol=1e-4)
    with pytest.raises(ValueError, match="latent"):
        CollisionNet(SMALL).check_logits(trilinear.channels_last(grid), poses)

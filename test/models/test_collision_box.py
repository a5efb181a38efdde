"""grow_box: the same network over a larger box computes what it did, and refuses boxes it cannot take."""

import pytest
import torch
import torch.nn.functional as F

from latent_planner_ros.models.collision_box import grow_box
from latent_planner_ros.models.collision_net import CollisionNet
from latent_planner_ros.models.collision_net_config import CollisionNetConfig
from latent_planner_ros.models.scene_encoder import SceneEncoderConfig
from latent_planner_ros.robot.limits import Q_MAX, Q_MIN

SMALL = CollisionNetConfig(
    encoder=SceneEncoderConfig(
        voxel_size=0.2, bounds_max=(1.0, 0.6, 0.55), point_hidden=8, point_features=8, conv_channels=(8, 6)
    ),
    hidden=(16,),
)


def _trained_like(config: CollisionNetConfig) -> CollisionNet:
    torch.manual_seed(0)
    net = CollisionNet(config)
    with torch.no_grad():  # weights far from their initialisation, so the position columns matter
        for p in net.parameters():
            p.add_(torch.randn_like(p) * 0.3)
    return net.eval()


def test_grown_network_reads_the_old_grid_as_the_old_network_did(rng):
    net = _trained_like(SMALL)
    grown = grow_box(net, (-0.2, -0.6, -0.05), (1.0, 0.8, 1.15))
    assert grown.config.encoder.grid_shape == (6, 7, 6) and net.config.encoder.grid_shape == (5, 6, 3)
    grid = torch.randn(2, 6, 5, 6, 3)
    # the old grid placed in the new one: one voxel lower in x, none in y and z; zeros elsewhere (the old padding)
    big = F.pad(grid, (0, 3, 0, 1, 1, 0))
    q = torch.as_tensor(rng.uniform(Q_MIN, Q_MAX, size=(2, 40, 7)), dtype=torch.float32)
    z = torch.randn(2, 40, SMALL.latent)
    with torch.no_grad():
        torch.testing.assert_close(grown.link_logits(big, q, z), net.link_logits(grid, q, z), atol=1e-4, rtol=1e-4)
        moved = grown.link_inputs(big, q, z)[..., 6 * 3 : 6 * 3 + 9]  # the position columns did change
        assert not torch.allclose(moved, net.link_inputs(grid, q, z)[..., 6 * 3 : 6 * 3 + 9])
    # the same encoder weights, and the original is untouched
    torch.testing.assert_close(grown.encoder.state_dict()["convs.0.weight"], net.encoder.state_dict()["convs.0.weight"])
    assert net.config.encoder.bounds_max == (1.0, 0.6, 0.55)


def test_grown_encoder_matches_far_from_the_old_faces(rng):
    net = _trained_like(SMALL)
    grown = grow_box(net, SMALL.encoder.bounds_min, (1.0, 0.6, 1.15))
    cloud = torch.as_tensor(rng.uniform([0.2, -0.2, -0.05], [0.8, 0.2, 0.1], size=(300, 3)), dtype=torch.float32)
    with torch.no_grad():
        old, new = net.encoder(cloud), grown.encoder(cloud)
    # two 3x3x3 convolutions over empty voxels beyond the old top face: only the old top layer of voxels
    # (index 2 of 3) sees the new voxels' biases instead of zero padding
    torch.testing.assert_close(new[..., :2], old[..., :2])
    assert not torch.allclose(new[..., 2], old[..., 2])


def test_boxes_it_cannot_take_are_refused():
    net = CollisionNet(SMALL)
    with pytest.raises(ValueError, match="contain"):
        grow_box(net, SMALL.encoder.bounds_min, (1.0, 0.6, 0.35))
    with pytest.raises(ValueError, match="grid"):
        grow_box(net, (-0.1, -0.6, -0.05), (1.0, 0.6, 0.75))
    with pytest.raises(ValueError, match="whole number"):
        grow_box(net, SMALL.encoder.bounds_min, (1.0, 0.6, 0.85))
    with pytest.raises(ValueError, match="3 components"):
        grow_box(net, SMALL.encoder.bounds_min, (1.0, 0.6))

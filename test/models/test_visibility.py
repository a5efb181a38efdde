"""The visibility channels: space seen free in front of observed surfaces, space hidden behind them."""

import numpy as np
import pytest
import torch

from latent_planner_ros.data.camera import look_at
from latent_planner_ros.data.obstacles import Box
from latent_planner_ros.data.render import scene_view
from latent_planner_ros.data.scene import Scene
from latent_planner_ros.models import visibility as vis
from latent_planner_ros.models.scene_encoder import SceneEncoder, SceneEncoderConfig

EYE = np.array([1.8, 0.0, 0.6])
BOX = Box((0.5, 0.0, 0.2), (0.0, 0.0, 0.0, 1.0), (0.1, 0.1, 0.2))  # x 0.4-0.6, z 0-0.4


@pytest.fixture(scope="module")
def view():
    cloud, eye = scene_view(Scene((BOX,)), np.random.default_rng(0), pose=look_at(EYE, np.array([0.5, 0.0, 0.2])))
    return cloud, eye


def _grid(encoder: SceneEncoder, cloud: np.ndarray, eye) -> np.ndarray:
    """(nx, ny, nz, 3) visibility channels of one cloud."""
    p = torch.as_tensor(cloud)
    eyes = torch.as_tensor(np.asarray(eye, dtype=np.float32).reshape(1, 3))
    cfg = encoder.config
    g = vis.visibility_grid(
        p, torch.zeros(len(p), dtype=torch.long), eyes, encoder.samples, encoder.centre, cfg.visibility_bin,
        cfg.visibility_margin_m,
    )  # fmt: skip
    return g[0].reshape(*cfg.grid_shape, 3).numpy()


def test_scene_view_returns_the_camera_origin(view):
    cloud, eye = view
    np.testing.assert_allclose(eye, EYE)
    assert len(cloud) > 1000


def test_voxels_in_front_of_the_box_are_free_and_behind_it_hidden(view):
    cloud, eye = view
    enc = SceneEncoder(SceneEncoderConfig(visibility=True))
    g = _grid(enc, cloud, eye)
    # voxel indices: x = 0.1 * i, y = -0.6 + 0.1 * j, z = -0.05 + 0.1 * k (lower corners); y = 0 is j = 6
    front = g[7:10, 6, 1:4]  # x 0.7-1.0, z 0.05-0.35: between the camera and the box's front face
    behind = g[0:3, 6, 1:4]  # x 0.0-0.3, z 0.05-0.35: behind the box
    assert front[..., 0].min() == 1.0 and front[..., 1].max() == 0.0
    assert behind[..., 1].min() == 1.0 and behind[..., 0].max() == 0.0
    assert np.all(g[..., 2] == 1.0)  # the origin is known


def test_an_unknown_origin_gives_zero_channels(view):
    cloud, _ = view
    enc = SceneEncoder(SceneEncoderConfig(visibility=True))
    assert np.all(_grid(enc, cloud, [np.nan] * 3) == 0.0)


def test_the_origin_changes_the_embedding_only_with_visibility(view):
    cloud, eye = view
    torch.manual_seed(0)
    with_vis = SceneEncoder(SceneEncoderConfig(visibility=True)).eval()
    a, b = with_vis.encode(cloud, eye).features, with_vis.encode(cloud).features
    assert not torch.allclose(a, b)
    torch.manual_seed(0)
    without = SceneEncoder(SceneEncoderConfig()).eval()
    torch.testing.assert_close(without.encode(cloud, eye).features, without.encode(cloud).features)


def test_batched_encoding_matches_one_cloud_at_a_time(view):
    cloud, eye = view
    torch.manual_seed(1)
    enc = SceneEncoder(SceneEncoderConfig(visibility=True)).eval()
    other = cloud[cloud[:, 2] < 0.1]  # the table alone
    pts = torch.as_tensor(np.concatenate([cloud, other]))
    batch = torch.cat([torch.zeros(len(cloud)), torch.ones(len(other))]).long()
    eyes = torch.as_tensor(np.stack([eye, [np.nan] * 3]), dtype=torch.float32)
    with torch.no_grad():
        both = enc(pts, batch, 2, eyes)
    torch.testing.assert_close(both[0], enc.encode(cloud, eye).features)
    torch.testing.assert_close(both[1], enc.encode(other).features)


def test_an_older_encoder_config_loads_without_visibility():
    d = SceneEncoderConfig().to_dict()
    for key in ("visibility", "visibility_bin", "visibility_margin_m"):
        d.pop(key)
    assert SceneEncoderConfig.from_dict(d).visibility is False

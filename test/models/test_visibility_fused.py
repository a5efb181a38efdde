"""Visibility channels of clouds fused from several cameras (one origin per point)."""

import numpy as np
import pytest
import torch

from latent_planner_ros.data.camera import look_at
from latent_planner_ros.data.obstacles import Box
from latent_planner_ros.data.render import scene_view
from latent_planner_ros.data.scene import Scene
from latent_planner_ros.models import visibility as vis
from latent_planner_ros.models.scene_encoder import SceneEncoder, SceneEncoderConfig, single_origin

FRONT = np.array([1.8, 0.0, 0.6])  # looks along -x at the box
SIDE = np.array([0.15, -0.9, 1.1])  # from the left, down onto the table behind the box
CENTRE = np.array([0.5, 0.0, 0.2])
BOX = Box((0.5, 0.0, 0.2), (0.0, 0.0, 0.0, 1.0), (0.1, 0.1, 0.2))  # x 0.4-0.6, y -0.1-0.1, z 0-0.4


@pytest.fixture(scope="module")
def views():
    scene, rng = Scene((BOX,)), np.random.default_rng(0)
    front, front_eye = scene_view(scene, rng, pose=look_at(FRONT, CENTRE))
    side, side_eye = scene_view(scene, rng, pose=look_at(SIDE, np.array([0.15, 0.2, 0.0])))
    return (front, front_eye), (side, side_eye)


@pytest.fixture(scope="module")
def encoder():
    torch.manual_seed(3)
    return SceneEncoder(SceneEncoderConfig(visibility=True)).eval()


def _single(enc: SceneEncoder, cloud: np.ndarray, eye) -> torch.Tensor:
    """(V, 3) channels of one cloud from one origin (the one-camera function)."""
    p = torch.as_tensor(cloud, dtype=torch.float32)
    e = torch.as_tensor(np.asarray(eye, dtype=np.float32).reshape(1, 3))
    c = enc.config
    zeros = torch.zeros(len(p), dtype=torch.long)
    return vis.visibility_grid(p, zeros, e, enc.samples, enc.centre, c.visibility_bin, c.visibility_margin_m)[0]


def _per_point(enc: SceneEncoder, cloud: np.ndarray, origins: np.ndarray) -> torch.Tensor:
    """(V, 3) channels of one cloud with one origin per point."""
    p = torch.as_tensor(cloud, dtype=torch.float32)
    o = torch.as_tensor(origins, dtype=torch.float32)
    c = enc.config
    zeros = torch.zeros(len(p), dtype=torch.long)
    out = vis.visibility_grid_per_point(
        p, zeros, 1, o, enc.samples, enc.centre, c.visibility_bin, c.visibility_margin_m
    )
    return out[0]


def test_per_point_origins_that_are_all_one_camera_equal_the_single_origin_exactly(views, encoder):
    (cloud, eye), _ = views
    origins = np.tile(eye, (len(cloud), 1))
    assert torch.equal(_per_point(encoder, cloud, origins), _single(encoder, cloud, eye))
    with torch.no_grad():
        a = encoder.encode(cloud, origins).features
        b = encoder.encode(cloud, eye).features
    assert torch.equal(a, b)
    np.testing.assert_array_equal(single_origin(origins), eye.astype(origins.dtype))


def test_single_origin_needs_one_finite_row():
    assert single_origin(np.zeros((0, 3))) is None
    assert single_origin(np.array([[1.0, 2.0, 3.0], [1.0, 2.0, 3.5]])) is None
    assert single_origin(np.array([[1.0, 2.0, np.nan]] * 2)) is None


def test_two_cameras_combine_free_and_hidden_per_sample(views, encoder):
    (front, front_eye), (side, side_eye) = views
    fused = np.concatenate([front, side])
    origins = np.concatenate([np.tile(front_eye, (len(front), 1)), np.tile(side_eye, (len(side), 1))])
    both = _per_point(encoder, fused, origins)
    a, b = _single(encoder, front, front_eye), _single(encoder, side, side_eye)
    # free: at least each camera's own free fraction; hidden: at most the smaller one where both see the voxel
    assert torch.all(both[:, 0] >= torch.maximum(a[:, 0], b[:, 0]) - 1e-6)
    assert torch.all(both[:, 0] + both[:, 1] <= 1.0 + 1e-6)
    assert torch.all(both[:, 2] == 1.0)
    g = both.reshape(*encoder.config.grid_shape, 3).numpy()
    ga = a.reshape(*encoder.config.grid_shape, 3).numpy()
    # behind the box for the front camera (x 0.0-0.3 at y = 0), but in plain view of the other one:
    behind = (slice(0, 3), 6, slice(1, 4))
    assert ga[behind][..., 1].min() == 1.0 and ga[behind][..., 0].max() == 0.0
    assert g[behind][..., 1].max() == 0.0 and g[behind][..., 0].min() > 0.5
    # the voxels inside the box stay hidden or on the surface for both: never free
    assert g[4:6, 5:7, 1:4, 0].max() == 0.0


def test_points_of_unknown_origin_see_nothing(views, encoder):
    (cloud, eye), _ = views
    origins = np.tile(eye, (len(cloud), 1))
    origins[::2] = np.nan
    partly = _per_point(encoder, cloud, origins)
    known_only = _single(encoder, cloud[1::2], eye)
    assert torch.equal(partly, known_only)
    assert torch.all(_per_point(encoder, cloud, np.full_like(origins, np.nan)) == 0.0)


def test_encode_refuses_origins_of_the_wrong_shape(views, encoder):
    (cloud, _), _ = views
    with pytest.raises(ValueError, match="eye"):
        encoder.encode(cloud, np.zeros((len(cloud) - 1, 3)))


@pytest.mark.parametrize("shuffle", [False, True])
def test_unique_rows_equals_torch_unique(shuffle):
    """The run-based distinct rows equal torch.unique(dim=0)'s, in runs (a fused cloud) and in any order."""
    g = torch.Generator().manual_seed(3)
    origins = torch.randn(4, 3, generator=g, dtype=torch.float64)
    counts = [500, 1, 250, 700]
    key = torch.cat(
        [torch.cat([torch.full((n, 1), float(k % 2)), origins[k].expand(n, 3)], 1) for k, n in enumerate(counts)]
    )
    key = torch.cat([key, key[:30]])  # a view seen again later: a second run of the same row
    if shuffle:
        key = key[torch.randperm(len(key), generator=g)]
    views, group = vis.unique_rows(key)
    ref_views, ref_group = torch.unique(key, dim=0, return_inverse=True)
    assert torch.equal(views, ref_views) and torch.equal(group, ref_group)
    assert torch.equal(views[group], key)
    for n in (0, 1):
        empty_views, empty_group = vis.unique_rows(key[:n])
        assert empty_views.shape == (n, 4) and empty_group.tolist() == [0] * n

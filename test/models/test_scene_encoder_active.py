"""The scene encoder's active box: only the voxels around the points above the floor are encoded."""

from dataclasses import replace

import numpy as np
import torch

from latent_planner_ros.models.scene_encoder import SceneEncoder, SceneEncoderConfig

BOX = SceneEncoderConfig(
    bounds_min=(-1.0, -1.0, -0.05), bounds_max=(1.0, 1.0, 1.25), point_hidden=8, point_features=8,
    conv_channels=(8, 8), visibility=True,
)  # fmt: skip
EYE = np.array([1.6, 0.7, 0.9], dtype=np.float32)


def _encoder(config: SceneEncoderConfig) -> SceneEncoder:
    torch.manual_seed(0)
    return SceneEncoder(config).eval()


def _cloud(rng: np.random.Generator) -> np.ndarray:
    table = np.c_[rng.uniform(-1, 1, (800, 2)), rng.normal(0.0, 0.004, 800)]
    box = rng.uniform([0.3, -0.2, 0.0], [0.5, 0.1, 0.3], (500, 3))
    return np.concatenate([table, box]).astype(np.float32)


def test_a_margin_covering_the_grid_is_the_whole_grid_encoder():
    cloud = _cloud(np.random.default_rng(0))
    whole = _encoder(BOX)
    wide = _encoder(replace(BOX, active_margin=30))
    with torch.no_grad():
        assert torch.equal(whole.encode(cloud, EYE).features, wide.encode(cloud, EYE).features)


def test_only_the_box_around_the_points_above_the_floor_has_features():
    cloud = _cloud(np.random.default_rng(1))
    enc = _encoder(replace(BOX, active_margin=1, floor_m=0.02, active_min_points=3))
    with torch.no_grad():
        f = enc.encode(cloud, EYE).features
    active = f.abs().sum(0) > 0
    ix, iy, iz = (torch.nonzero(active.any(d)).flatten() for d in ((1, 2), (0, 2), (0, 1)))
    # the box's voxels: x 0.3-0.5 -> 13-14, y -0.2-0.1 -> 8-11, z 0-0.3 -> 0-3 (floor at 2 cm), grown by 1
    assert (ix.min(), ix.max(), iy.min(), iy.max(), iz.min(), iz.max()) == (12, 15, 7, 11, 0, 4)
    assert active.float().mean() < 0.05  # the table's points (below the floor) open nothing
    empty = enc.encode(cloud[cloud[:, 2] < 0.02], EYE).features
    assert not empty.any()  # nothing above the floor: no features anywhere


def test_a_batch_equals_its_clouds_one_by_one_and_trains():
    rng = np.random.default_rng(2)
    a, b = _cloud(rng), _cloud(rng)[:900] + np.array([-0.8, 0.3, 0.2], dtype=np.float32)
    enc = _encoder(replace(BOX, active_margin=2, floor_m=0.02))
    points = torch.as_tensor(np.concatenate([a, b]))
    batch = torch.cat([torch.zeros(len(a)), torch.ones(len(b))]).long()
    eyes = torch.as_tensor(np.stack([EYE, -EYE]))
    with torch.no_grad():
        both = enc(points, batch, 2, eyes=eyes)
        one = enc(torch.as_tensor(a), eyes=eyes[:1])[0]
        two = enc(torch.as_tensor(b), eyes=eyes[1:])[0]
    assert torch.allclose(both[0], one, atol=1e-5) and torch.allclose(both[1], two, atol=1e-5)
    loss = enc(points, batch, 2, eyes=eyes).square().mean()
    loss.backward()
    assert all(p.grad is not None and torch.isfinite(p.grad).all() for p in enc.parameters())

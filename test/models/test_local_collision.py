"""The local collision predictor: neighbourhoods, link-frame features, gradients, checkpoints, its backend."""

from __future__ import annotations

import numpy as np
import pytest
import torch
from scipy.spatial import cKDTree
from scipy.spatial.transform import Rotation

from latent_planner_ros.data.link_geometry import LABEL_LINKS
from latent_planner_ros.models.checkpoint import CheckpointError, save_checkpoint
from latent_planner_ros.models.local_collision import (
    LocalCollisionConfig,
    LocalCollisionNet,
    Neighbourhoods,
    hull_planes,
)
from latent_planner_ros.models.local_collision_io import KIND, load_local_collision
from latent_planner_ros.models.local_predictor import LocalPredictor
from latent_planner_ros.planning.local_backend import LocalBackend
from latent_planner_ros.robot.limits import Q_READY
from latent_planner_ros.robot.panda import LINK_FRAMES
from latent_planner_ros.robot.torch_fk import TorchFK

CONFIG = LocalCollisionConfig(k=4, hidden=16)
LABEL = [LINK_FRAMES.index(n) for n in LABEL_LINKS]


@pytest.fixture(scope="module")
def net():
    torch.manual_seed(0)
    return LocalCollisionNet(CONFIG).eval()


def _frames(q: np.ndarray) -> np.ndarray:
    return TorchFK().frames_np(np.atleast_2d(q))[:, LABEL]


def _wall(x: float = 0.55) -> np.ndarray:
    """A wall of points at x [m] in front of the ready pose's hand, 1 cm apart."""
    y, z = np.meshgrid(np.arange(-0.3, 0.3, 0.01), np.arange(0.0, 0.8, 0.01))
    return np.stack([np.full(y.size, x), y.ravel(), z.ravel()], 1).astype(np.float32)


def test_neighbourhoods_take_the_nearest_points_within_the_radius_only(net):
    frames = _frames(Q_READY)
    anchors = net.anchors_np()
    hand = LABEL_LINKS.index("panda_hand")
    centre = frames[0, hand, :3, :3] @ anchors[hand, 1] + frames[0, hand, :3, 3]
    near = centre + np.array([[0.02, 0, 0], [0, 0.03, 0], [0, 0, -0.01]])
    cloud = np.concatenate([near, centre + [[0.5, 0, 0]]]).astype(np.float32)
    nb = Neighbourhoods.of(cKDTree(cloud), cloud, None, frames, anchors, net.config)
    k = net.config.k
    got = nb.points[0, hand, k : 2 * k][nb.valid[0, hand, k : 2 * k]].numpy()
    assert len(got) == 3  # the far point is beyond radius_m
    np.testing.assert_allclose(sorted(np.linalg.norm(got - centre, axis=1)), [0.01, 0.02, 0.03], atol=1e-6)
    assert torch.isnan(nb.eyes).all()  # no camera origins given
    empty = Neighbourhoods.of(None, np.zeros((0, 3), np.float32), None, frames, anchors, net.config)
    assert not empty.valid.any()


def test_a_point_inside_a_links_hull_has_a_negative_hull_distance(net):
    frames = torch.as_tensor(_frames(Q_READY), dtype=torch.float32)
    hand = LABEL_LINKS.index("panda_hand")
    anchors = net.anchors_np()
    f = frames[0, hand].double().numpy()
    inside = f[:3, :3] @ anchors[hand, 1] + f[:3, 3]  # an anchor lies on the link's axis, within its hull
    outside = inside + f[:3, :3] @ np.array([0.0, 0.0, 0.3])
    pts = torch.zeros(1, len(LABEL_LINKS), 2, 3)
    pts[0, hand] = torch.as_tensor(np.stack([inside, outside]), dtype=torch.float32)
    nb = Neighbourhoods(pts, torch.full_like(pts, float("nan")), torch.ones(1, len(LABEL_LINKS), 2, dtype=torch.bool))
    _, hull = net.features(frames, nb)
    assert hull[0, hand, 0] < 0 < hull[0, hand, 1]
    assert hull_planes(8).shape == (len(LABEL_LINKS), 8, 4)


def test_the_logits_do_not_change_when_the_whole_scene_moves_rigidly(net):
    """Features are expressed in each link's frame: moving the cloud, the cameras and the arm together changes
    nothing."""
    q = np.array([Q_READY, Q_READY + 0.3])
    frames = _frames(q)
    cloud = _wall(0.45)
    eye = np.array([1.5, 0.2, 0.8], dtype=np.float32)
    nb = Neighbourhoods.of(cKDTree(cloud), cloud, np.tile(eye, (len(cloud), 1)), frames, net.anchors_np(), CONFIG)
    assert nb.valid.any()
    m = np.eye(4)
    m[:3, :3] = Rotation.from_euler("xyz", [0.3, -0.5, 1.1]).as_matrix()
    m[:3, 3] = [0.2, -0.7, 0.4]
    moved = (cloud @ m[:3, :3].T + m[:3, 3]).astype(np.float32)
    eye2 = (m[:3, :3] @ eye + m[:3, 3]).astype(np.float32)
    frames2 = m @ frames
    nb2 = Neighbourhoods.of(cKDTree(moved), moved, np.tile(eye2, (len(moved), 1)), frames2, net.anchors_np(), CONFIG)
    with torch.no_grad():
        a = net(torch.as_tensor(frames, dtype=torch.float32), nb)
        b = net(torch.as_tensor(frames2, dtype=torch.float32), nb2)
    np.testing.assert_allclose(a.numpy(), b.numpy(), atol=2e-4)


def test_gradients_reach_the_joints_through_the_backend(net, tmp_path):
    backend = LocalBackend(LocalPredictor(net))
    backend.set_scene(_wall(0.4), np.array([1.5, 0.0, 0.6]))  # 9 cm in front of the hand
    q = torch.tensor(np.array([Q_READY]), dtype=torch.float32, requires_grad=True)
    p = backend.p_collision(q, torch.zeros(1, 7))
    p.sum().backward()
    assert p.shape == (1,) and 0.0 < float(p.detach()) < 1.0
    assert q.grad is not None and float(q.grad.abs().sum()) > 0.0


def test_the_hard_check_refuses_an_observed_point_inside_the_arm_and_passes_an_empty_scene(net):
    backend = LocalBackend(LocalPredictor(net), threshold=1.1)  # the network never refuses: the geometric part
    q = np.array([Q_READY])
    backend.set_scene(np.zeros((0, 3), np.float32))
    assert not backend.check(q).any()
    tcp = TorchFK().frames_np(q)[0, LINK_FRAMES.index("panda_hand")][:3, 3]
    backend.set_scene(np.array([tcp], dtype=np.float32))
    assert backend.check(q).all()
    with pytest.raises(ValueError, match="origin"):
        backend.set_scene(np.zeros((4, 3), np.float32), np.zeros((2, 3)))


def test_a_checkpoint_round_trip_gives_the_same_logits_and_the_wrong_kind_is_refused(net, tmp_path):
    save_checkpoint(tmp_path / "local", dict(net.state_dict()), {"kind": KIND, "architecture": CONFIG.to_dict()})
    loaded, meta = load_local_collision(tmp_path / "local")
    assert meta["kind"] == KIND and loaded.config == CONFIG
    pred_a, pred_b = LocalPredictor(net), LocalPredictor(loaded)
    q = torch.as_tensor(np.array([Q_READY, Q_READY - 0.2]), dtype=torch.float32)
    with torch.no_grad():
        a = pred_a.link_logits_q(pred_a.encode(_wall(), np.array([1.5, 0, 0.6])), q)
        b = pred_b.link_logits_q(pred_b.encode(_wall(), np.array([1.5, 0, 0.6])), q)
    torch.testing.assert_close(a, b)
    save_checkpoint(tmp_path / "other", dict(net.state_dict()), {"kind": "collision_net", "architecture": {}})
    with pytest.raises(CheckpointError, match="not a local collision predictor"):
        load_local_collision(tmp_path / "other")
    with pytest.raises(CheckpointError):
        load_local_collision(tmp_path / "missing")


def test_the_occupancy_prefilter_gives_the_same_neighbourhoods(net):
    from latent_planner_ros.planning.ball_query import BallQuery

    rng = np.random.default_rng(3)
    q = Q_READY + rng.uniform(-0.6, 0.6, (40, 7))
    frames = _frames(q)
    cloud = np.concatenate([_wall(0.45), rng.uniform([-0.5, -0.5, 0], [0.8, 0.5, 1.0], (300, 3))]).astype(np.float32)
    eyes = np.tile(np.array([1.5, 0.0, 0.8], np.float32), (len(cloud), 1))
    tree = cKDTree(cloud)
    plain = Neighbourhoods.of(tree, cloud, eyes, frames, net.anchors_np(), CONFIG)
    fast = Neighbourhoods.of(tree, cloud, eyes, frames, net.anchors_np(), CONFIG, BallQuery(cloud).occupied)
    assert plain.valid.any() and not plain.valid.all()
    assert torch.equal(plain.valid, fast.valid)
    torch.testing.assert_close(plain.points[plain.valid], fast.points[fast.valid])
    torch.testing.assert_close(plain.eyes[plain.valid], fast.eyes[fast.valid])

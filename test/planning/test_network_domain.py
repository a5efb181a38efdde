"""The learned backend plans with the geometric one when the scene lies beyond the network's box or was fused
from more cameras than the network learned from."""

import numpy as np
import torch

from latent_planner_ros.planning.geometric_backend import GeometricBackend
from latent_planner_ros.planning.learned_backend import LearnedBackend, count_views
from latent_planner_ros.planning.network_domain import share_outside
from latent_planner_ros.robot.limits import Q_READY

BOX = ((0.0, -0.6, -0.05), (1.0, 0.6, 0.95))


def _block(lo, hi, n=3000, seed=0) -> np.ndarray:
    return np.random.default_rng(seed).uniform(lo, hi, (n, 3)).astype(np.float32)


def test_share_outside_counts_occupied_voxels_above_the_table():
    table = _block((-1, -1, -0.01), (1, 1, 0.01))  # the table top everywhere: not part of the scene here
    inside = _block((0.3, -0.2, 0.0), (0.5, 0.2, 0.3))
    behind = _block((-0.8, -0.2, 0.0), (-0.6, 0.2, 0.3))  # as many voxels as `inside`, behind the robot
    assert share_outside(table, *BOX) == 0.0 and share_outside(np.zeros((0, 3)), *BOX) == 0.0
    assert share_outside(np.concatenate([table, inside]), *BOX) == 0.0
    assert share_outside(np.concatenate([inside, behind]), *BOX) == 0.5
    stray = np.array([[-0.9, 0.9, 0.5], [-0.9, 0.9, 0.52]])  # two noise points: not an occupied voxel
    assert share_outside(np.concatenate([inside, stray]), *BOX) == 0.0


def test_a_scene_beyond_the_box_is_planned_with_the_geometric_backend():
    learned, geometric = LearnedBackend.load(), GeometricBackend()
    inside = _block((0.3, -0.2, 0.0), (0.6, 0.2, 0.4))
    workcell = np.concatenate([inside, _block((-0.7, -0.5, 0.0), (-0.3, 0.5, 0.9), 8000, 1)])
    q = Q_READY + np.random.default_rng(2).normal(0, 0.6, (64, 7))
    learned.set_scene(inside, np.array([1.6, 0.7, 0.9]))
    assert learned.mode == "learned"
    learned.set_scene(workcell, np.array([1.6, 0.7, 0.9]))
    geometric.set_scene(workcell)
    assert learned.mode == "geometric"
    np.testing.assert_array_equal(learned.check(q), geometric.check(q))
    qt, z = torch.as_tensor(q, dtype=torch.float32), torch.zeros(64, 7)
    assert torch.equal(learned.p_collision(qt, z), geometric.p_collision(qt, z))
    learned.set_cloud(inside)  # the node's path: an embedding, then the raw cloud
    assert learned.mode == "learned"
    never = LearnedBackend.load(domain_share=1.0)
    never.set_scene(workcell, np.array([1.6, 0.7, 0.9]))
    assert never.mode == "learned"


def test_a_cloud_fused_from_several_cameras_is_planned_with_the_geometric_backend():
    learned, geometric = LearnedBackend.load(), GeometricBackend()
    inside = _block((0.3, -0.2, 0.0), (0.6, 0.2, 0.4))  # well inside the box
    one = np.tile([1.6, 0.7, 0.9], (len(inside), 1))
    two = one.copy()
    two[len(inside) // 2 :] = [1.6, -0.7, 0.9]  # the second half seen from another camera
    learned.set_scene(inside, one)
    assert learned.mode == "learned"
    learned.set_scene(inside, two)
    geometric.set_scene(inside)
    assert learned.mode == "geometric"
    q = Q_READY + np.random.default_rng(3).normal(0, 0.6, (64, 7))
    np.testing.assert_array_equal(learned.check(q), geometric.check(q))
    learned.set_cloud(inside, views=1)  # the node's path: an embedding, then the raw cloud and its topics
    assert learned.mode == "learned"
    learned.set_cloud(inside, views=3)
    assert learned.mode == "geometric"
    any_views = LearnedBackend.load(max_views=0)
    any_views.set_scene(inside, two)
    assert any_views.mode == "learned"


def test_count_views_counts_distinct_finite_origins():
    a, b = [0.0, 1.0, 2.0], [1.0, 0.0, 2.0]
    assert count_views(None) == 1 and count_views(np.array(a)) == 1 and count_views(np.zeros((0, 3))) == 1
    assert count_views(np.array([a, a, b, b, a])) == 2  # runs in any order
    assert count_views(np.array([a, [np.nan] * 3, b, [5.0, 5.0, 5.0]])) == 3
    assert count_views(np.full((4, 3), np.nan)) == 1

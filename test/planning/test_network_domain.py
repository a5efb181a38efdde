"""The learned backend plans with the geometric one when the scene lies beyond the network's box."""

import numpy as np
import torch

from latent_planner_ros.planning.geometric_backend import GeometricBackend
from latent_planner_ros.planning.learned_backend import LearnedBackend
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

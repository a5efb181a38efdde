"""Per-link collision probabilities of the backends (the planner's status `p_collision_links`, the view's colours)."""

from __future__ import annotations

import numpy as np

from latent_planner_ros.planning.geometric_backend import GeometricBackend
from latent_planner_ros.robot.panda import load_panda

Q = np.array([0.0, -0.3, 0.0, -2.0, 0.0, 1.7, 0.8])


def test_the_link_at_an_observed_point_is_the_likely_one_and_far_links_are_free():
    backend = GeometricBackend()
    hand = load_panda().fk(Q, "panda_hand").translation
    backend.set_scene(hand[None])
    p = backend.link_p_collision(Q)
    assert max(p, key=p.get) in ("panda_hand", "panda_link7") and p["panda_hand"] > 0.9
    assert p["panda_link1"] < 0.05 and p["panda_link2"] < 0.05
    assert "panda_link0" not in p  # the base stands on the table: never a cost
    # the arm's probability (the max over its spheres) is the largest link probability
    import torch

    arm = float(backend.p_collision(torch.as_tensor(Q[None], dtype=torch.float32), torch.zeros(1, 7))[0])
    assert abs(arm - max(p.values())) < 1e-5


def test_an_empty_scene_leaves_every_link_free():
    backend = GeometricBackend()
    backend.set_scene(np.zeros((0, 3)))
    assert max(backend.link_p_collision(Q).values()) < 0.01

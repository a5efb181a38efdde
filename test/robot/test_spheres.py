"""The sphere model covers the collision geometry and flags what the exact check flags."""

import numpy as np
import torch

from latent_planner_ros.robot.collision import CollisionChecker
from latent_planner_ros.robot.limits import Q_MAX, Q_MIN, Q_READY
from latent_planner_ros.robot.panda import LINK_FRAMES
from latent_planner_ros.robot.spheres import _link_points, panda_spheres
from latent_planner_ros.robot.torch_fk import TorchFK


def test_spheres_contain_every_vertex_of_their_link():
    model = panda_spheres()
    for name, pts in _link_points(np.random.default_rng(1)).items():
        mine = model.link == LINK_FRAMES.index(name)
        d = np.linalg.norm(pts[:, None, :] - model.centre[mine][None], axis=-1) - model.radius[mine][None]
        assert d.min(axis=1).max() <= 1e-9, name


def test_penetration_agrees_with_the_exact_check(rng):
    model, fk = panda_spheres(), TorchFK()
    q = rng.uniform(Q_MIN, Q_MAX, size=(1500, 7))
    c = model.centres_world(fk(torch.as_tensor(q, dtype=torch.float32)))
    self_pen = (model.self_penetration(c) > 0).numpy()
    table_pen = (model.table_penetration(c) > 0).numpy()
    exact = np.array([CollisionChecker().collisions(qi) for qi in q[:1500]])
    # conservative: almost every exact collision is flagged by the spheres
    assert (exact[:, 0] & ~self_pen).mean() < 0.01
    assert (exact[:, 1] & ~table_pen).mean() < 0.005
    ready = model.centres_world(fk(torch.as_tensor(Q_READY, dtype=torch.float32)))
    assert float(model.self_penetration(ready)) == 0.0 and float(model.table_penetration(ready)) == 0.0


def test_penetration_is_differentiable():
    model, fk = panda_spheres(), TorchFK(dtype=torch.float64)
    q = torch.tensor([[0.0, 0.0, 0.0, -2.9, 0.0, 0.5, 0.0]], dtype=torch.float64, requires_grad=True)
    pen = model.self_penetration(model.centres_world(fk(q)))
    assert float(pen.detach()) > 0
    pen.sum().backward()
    assert torch.isfinite(q.grad).all() and q.grad.abs().sum() > 0

"""The geometric backend's cost: nearest-point clearances agree with the distance field and are exact."""

import numpy as np
import pytest
import torch

from latent_planner_ros.planning.geometric_backend import GeometricBackend, GeometricBackendConfig
from latent_planner_ros.robot.limits import Q_READY


def test_nearest_clearance_is_the_exact_distance_and_its_gradient_points_away():
    backend = GeometricBackend()
    q = torch.as_tensor(Q_READY[None], dtype=torch.float32)
    centres = backend._centres(q)[0].detach().numpy()
    point = centres[10] + np.array([0.0, 0.0, 0.12])  # 12 cm above one sphere's centre
    backend.set_scene(point[None])
    c = torch.tensor(centres[None], dtype=torch.float32, requires_grad=True)
    clearance = backend._nearest_clearance(c)
    exact = np.linalg.norm(centres - point, axis=1)
    expected = np.minimum(exact, backend.config.cost_range) - backend._radius.numpy()
    np.testing.assert_allclose(clearance.detach().numpy()[0], expected, atol=1e-5)
    clearance[0, 10].backward()
    np.testing.assert_allclose(c.grad[0, 10].numpy(), [0.0, 0.0, -1.0], atol=1e-5)  # away from the point
    empty = GeometricBackend()
    np.testing.assert_allclose(empty.clearance(q)[0].numpy(), empty.config.cost_range - empty._radius.numpy())


def test_nearest_and_field_clearances_agree_within_a_voxel():
    rng = np.random.default_rng(0)
    cloud = rng.uniform([0.2, -0.4, 0.0], [0.8, 0.4, 0.6], size=(400, 3))
    nearest, field = GeometricBackend(), GeometricBackend(GeometricBackendConfig(distance="field"))
    for b in (nearest, field):
        b.set_scene(cloud)
    q = torch.as_tensor(Q_READY + rng.normal(0.0, 0.3, size=(16, 7)), dtype=torch.float32)
    a, b = nearest.clearance(q), field.clearance(q)
    close = a + nearest._radius < nearest.config.cost_range - 0.01  # spheres within the nearest cost's range
    assert close.sum() > 20
    assert torch.all((a[close] - b[close]).abs() < 0.02)  # the field's voxels are 2 cm


def test_a_bad_distance_setting_is_refused():
    with pytest.raises(ValueError, match="distance must be"):
        GeometricBackendConfig(distance="voxels")
    with pytest.raises(ValueError, match="cost_range"):
        GeometricBackendConfig(cost_range=0.0)


def test_cost_from_given_link_frames_equals_its_own_fk():
    """AmpLs passes the link frames of its decoder's FK: the cost and its gradient are those of the backend's FK."""
    from latent_planner_ros.robot.torch_fk import TorchFK

    rng = np.random.default_rng(1)
    backend = GeometricBackend()
    backend.set_scene(rng.uniform([0.2, -0.4, 0.0], [0.8, 0.4, 0.6], size=(400, 3)))
    assert backend.takes_frames
    q0 = torch.as_tensor(Q_READY + rng.normal(0.0, 0.3, size=(8, 7)), dtype=torch.float32)
    q1 = q0.clone().requires_grad_(True)
    q2 = q0.clone().requires_grad_(True)
    own = backend.p_collision(q1, torch.zeros(8, 4))
    given = backend.p_collision(q2, torch.zeros(8, 4), frames=TorchFK()(q2))
    assert own.max() > 0.5 > own.min()  # some configurations near the points, some not
    torch.testing.assert_close(given, own)
    own.sum().backward()
    given.sum().backward()
    torch.testing.assert_close(q2.grad, q1.grad)

"""6D <-> matrix <-> quaternion conversions."""

import numpy as np
import pytest
import torch
from scipy.spatial.transform import Rotation

from latent_planner_ros.robot.rotations import (
    matrix_to_quat,
    matrix_to_rot6d,
    matrix_to_rot6d_np,
    quat_to_matrix,
    rot6d_to_matrix,
    rot6d_to_matrix_np,
    rotation_angle_between,
)


def test_rot6d_round_trip(rng):
    r = Rotation.random(500, random_state=1).as_matrix()
    np.testing.assert_allclose(rot6d_to_matrix_np(matrix_to_rot6d_np(r)), r, atol=1e-12)


def test_gram_schmidt_makes_a_rotation_from_any_6d(rng):
    d6 = torch.as_tensor(rng.normal(size=(200, 6)))
    r = rot6d_to_matrix(d6)
    eye = torch.eye(3, dtype=r.dtype).expand_as(r)
    torch.testing.assert_close(r.transpose(-1, -2) @ r, eye, atol=1e-12, rtol=0)
    assert torch.allclose(torch.linalg.det(r), torch.ones(200, dtype=r.dtype))
    # first column keeps the direction of the first 3-vector
    torch.testing.assert_close(r[:, :, 0], d6[:, :3] / d6[:, :3].norm(dim=-1, keepdim=True))


def test_quaternion_round_trip_and_sign(rng):
    q = rng.normal(size=(300, 4))
    q /= np.linalg.norm(q, axis=-1, keepdims=True)
    back = matrix_to_quat(quat_to_matrix(q))
    assert np.all(back[:, 3] >= 0)
    dots = np.abs(np.sum(back * q, axis=-1))
    np.testing.assert_allclose(dots, 1.0, atol=1e-12)
    # unnormalised input is normalised
    np.testing.assert_allclose(quat_to_matrix(3.0 * q[:5]), quat_to_matrix(q[:5]), atol=1e-12)


@pytest.mark.parametrize("bad", [[0, 0, 0, 0], [np.nan, 0, 0, 1], [np.inf, 0, 0, 1], [0, 0, 1]])
def test_bad_quaternions_are_refused(bad):
    with pytest.raises(ValueError):
        quat_to_matrix(np.array(bad, dtype=float))


def test_angle_between():
    a = torch.as_tensor(Rotation.from_euler("z", 0.3).as_matrix())
    b = torch.as_tensor(Rotation.from_euler("z", -0.2).as_matrix())
    assert abs(float(rotation_angle_between(a, b)) - 0.5) < 1e-9
    assert float(rotation_angle_between(a, a)) < 1e-6
    assert matrix_to_rot6d(a).shape == (6,)

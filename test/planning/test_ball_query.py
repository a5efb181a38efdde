"""The sphere-containment query equals brute force, and the geometric hard check built on it equals a direct
distance computation over the arm's spheres."""

import numpy as np
import pytest
import torch

from latent_planner_ros.planning.ball_query import MAX_CELLS, BallQuery
from latent_planner_ros.planning.geometric_backend import GeometricBackend, GeometricBackendConfig


def _brute(cloud: np.ndarray, centres: np.ndarray, radii: np.ndarray) -> np.ndarray:
    d = np.linalg.norm(centres[:, None] - cloud[None], axis=2).min(axis=1)
    return d < radii


@pytest.mark.parametrize("cell", [0.005, 0.02, 0.1])
def test_occupied_equals_brute_force_near_and_far(cell):
    rng = np.random.default_rng(0)
    cloud = rng.uniform(-0.3, 0.3, (400, 3)) * [1.0, 1.0, 0.1]  # a thin slab
    near = cloud[rng.integers(0, len(cloud), 300)] + rng.normal(0, 0.03, (300, 3))
    far = rng.uniform(-1.0, 1.0, (300, 3))  # many outside the occupancy grid
    centres = np.concatenate([near, far])
    radii = rng.uniform(0.0, 0.1, len(centres))
    got = BallQuery(cloud, cell).occupied(centres, radii)
    want = _brute(cloud, centres, radii)
    assert want.sum() > 50 and (~want).sum() > 50  # both answers are exercised
    np.testing.assert_array_equal(got, want)


def test_occupied_edge_cases():
    cloud = np.array([[0.0, 0.0, 0.0], [0.5, 0.5, 0.5]])
    q = BallQuery(cloud)
    # strictly inside: a point on the sphere's surface does not count
    np.testing.assert_array_equal(q.occupied([[0.1, 0, 0], [0.1, 0, 0]], [0.1, 0.1001]), [False, True])
    np.testing.assert_array_equal(q.occupied([[np.nan, 0, 0], [5, 5, 5]], 0.05), [True, False])
    assert q.occupied(np.zeros((0, 3)), 0.1).shape == (0,)
    empty = BallQuery(np.zeros((0, 3)))
    np.testing.assert_array_equal(empty.occupied([[0, 0, 0]], 10.0), [False])


@pytest.mark.parametrize("margin", [0.0, 0.02])
def test_geometric_check_equals_sphere_distances(margin):
    rng = np.random.default_rng(1)
    backend = GeometricBackend(GeometricBackendConfig(check_margin=margin, exact_margin=None))  # the spheres alone
    q = rng.uniform(-1.5, 1.5, (60, 7)) * [1, 1, 1, 0.5, 1, 1, 1] + [0, 0, 0, -1.8, 0, 1.5, 0]
    with torch.no_grad():
        centres = backend._centres(torch.as_tensor(q, dtype=torch.float32)).numpy()
    cloud = rng.uniform([0.3, -0.3, 0.2], [0.6, 0.3, 0.6], (300, 3))  # a block of points in front of the arm
    backend.set_check_cloud(cloud)
    radius = backend._radius.numpy()
    d = np.linalg.norm(centres.reshape(-1, 1, 3) - cloud[None], axis=2).min(axis=1).reshape(centres.shape[:2])
    want = np.any(d - radius < margin, axis=1)
    assert 0 < want.sum() < len(q)
    np.testing.assert_array_equal(backend.check(q), want)


def test_far_outliers_keep_the_grid_small_and_the_answers_exact():
    rng = np.random.default_rng(2)
    cloud = np.concatenate([rng.uniform(-0.5, 0.5, (500, 3)), [[1e5, -1e5, 3e4]]])
    q = BallQuery(cloud)
    assert q._prefix.size <= 1.25 * MAX_CELLS and q.cell > 0.02
    centres = np.concatenate([cloud[:200] + rng.normal(0, 0.02, (200, 3)), [[1e5, -1e5, 3e4 + 0.01]]])
    radii = rng.uniform(0.0, 0.05, len(centres))
    radii[-1] = 0.02
    np.testing.assert_array_equal(q.occupied(centres, radii), _brute(cloud, centres, radii))


def test_a_cloud_spread_far_along_one_axis_only_keeps_the_grid_small_and_the_answers_exact():
    """One outlier 1e9 m out along x (the other axes span 1 m): one cube-root coarsening left about 5e7 cells."""
    rng = np.random.default_rng(3)
    cloud = np.concatenate([rng.uniform(-0.5, 0.5, (500, 3)), [[1e9, 0.0, 0.0]]])
    q = BallQuery(cloud)
    assert q._prefix.size <= 1.25 * MAX_CELLS
    centres = np.concatenate([cloud[:200] + rng.normal(0, 0.02, (200, 3)), [[1e9, 0.0, 0.01]]])
    radii = rng.uniform(0.0, 0.05, len(centres))
    radii[-1] = 0.02
    np.testing.assert_array_equal(q.occupied(centres, radii), _brute(cloud, centres, radii))


@pytest.mark.parametrize("cell", [0.01, 0.02])
def test_the_prefilters_bound_the_exact_answer(cell):
    """maybe_occupied is False only where no point is inside, surely_occupied True only where one is; both are
    exercised (a dense slab gives voxels wholly inside the larger spheres)."""
    rng = np.random.default_rng(4)
    cloud = rng.uniform(-0.3, 0.3, (20000, 3)) * [1.0, 1.0, 0.2]
    centres = np.concatenate([rng.uniform(-0.4, 0.4, (600, 3)), [[np.nan, 0.0, 0.0]]])
    radii = rng.uniform(0.0, 0.12, len(centres))
    q = BallQuery(cloud, cell)
    want = np.append(_brute(cloud, centres[:-1], radii[:-1]), True)
    maybe, sure = q.maybe_occupied(centres, radii), q.surely_occupied(centres, radii)
    assert not (want & ~maybe).any() and not (sure & ~want).any()
    assert maybe[-1] and not sure[-1]  # a non-finite centre: refused by the filter, never a sure hit
    assert sure.sum() > 20 and (maybe & ~want).sum() > 10  # both filters decide some, and leave some open
    empty = BallQuery(np.zeros((0, 3)))
    assert not empty.maybe_occupied([[0, 0, 0]], 1.0)[0] and not empty.surely_occupied([[0, 0, 0]], 1.0)[0]

"""The geometric hard check's exact stage: the spheres find candidate points, the link hulls decide."""

import numpy as np

from latent_planner_ros.planning.geometric_backend import GeometricBackend, GeometricBackendConfig
from latent_planner_ros.robot.link_hulls import hull_inner_balls, link_hull_planes, link_vertices, plane_distance
from latent_planner_ros.robot.panda import LINK_FRAMES
from latent_planner_ros.robot.spheres import _link_points, panda_spheres
from latent_planner_ros.robot.torch_fk import TorchFK

READY = np.array([0.0, -0.785, 0.0, -2.356, 0.0, 1.571, 0.785])
HAND = LINK_FRAMES.index("panda_hand")


def test_each_hull_contains_its_link_geometry():
    assert set(link_vertices()) == set(_link_points(np.random.default_rng(1)))
    for name, pts in _link_points(np.random.default_rng(1)).items():  # vertices and points on the boxes' faces
        assert plane_distance(link_hull_planes()[LINK_FRAMES.index(name)], pts).max() < 1e-9, name


def _probe(offset: float) -> np.ndarray:
    """A point `offset` [m] out of the hand's hull (along the normal of a facet through one of its vertices) that
    lies inside one of the hand's spheres, in `world` at READY."""
    planes, spheres = link_hull_planes()[HAND], panda_spheres()
    mine = spheres.link == HAND
    best, slack = None, -np.inf
    for v in link_vertices()["panda_hand"]:
        n = planes[np.argmax(planes[:, :3] @ v + planes[:, 3]), :3]
        p = v + 0.02 * n  # the farthest probe must still be inside a sphere
        room = (spheres.radius[mine] - np.linalg.norm(spheres.centre[mine] - p, axis=1)).max()
        if room > slack:
            best, slack = (v, n), room
    assert slack > 0.002
    v, n = best
    pose = TorchFK().frames_np(READY[None])[0, HAND]
    return pose[:3, :3] @ (v + offset * n) + pose[:3, 3]


def test_points_in_a_sphere_but_off_the_hull_are_accepted_and_near_ones_refused():
    exact, spheres = GeometricBackend(), GeometricBackend(GeometricBackendConfig(exact_margin=None))
    near = _probe(0.02)
    spheres.set_scene(near[None])
    exact.set_scene(near[None])
    assert spheres.check(READY)[0]  # the spheres alone refuse it
    assert not exact.check(READY)[0]  # 2 cm off the hand's hull: not a collision
    for closer in (_probe(0.0), _probe(0.008)):  # on the hull, and within the 1 cm margin
        exact.set_scene(np.stack([near, closer]))
        assert exact.check(READY)[0]
        assert exact.check(np.stack([READY, READY + 0.4, READY])).tolist() == [True, False, True]


def _block_scene(seed: int, points: int):
    """60 configurations around the ready pose, a block of `points` random points in front of the arm, the backend
    holding it, and the configurations' link frames."""
    rng = np.random.default_rng(seed)
    backend = GeometricBackend()
    q = rng.uniform(-1.5, 1.5, (60, 7)) * [1, 1, 1, 0.5, 1, 1, 1] + [0, 0, 0, -1.8, 0, 1.5, 0]
    cloud = rng.uniform([0.3, -0.3, 0.2], [0.6, 0.3, 0.6], (points, 3))
    backend.set_check_cloud(cloud)
    return backend, q, cloud, TorchFK().frames_np(q)


def test_the_exact_stage_equals_a_brute_force_check():
    backend, q, cloud, frames = _block_scene(1, 300)
    spheres = panda_spheres()
    want = np.zeros(len(q), dtype=bool)
    for i in range(len(q)):
        for s in np.flatnonzero(spheres.link != LINK_FRAMES.index("panda_link0")):
            pose = frames[i, spheres.link[s]]
            centre = pose[:3, :3] @ spheres.centre[s] + pose[:3, 3]
            inside = cloud[np.linalg.norm(cloud - centre, axis=1) <= spheres.radius[s]]
            local = (inside - pose[:3, 3]) @ pose[:3, :3]
            planes = link_hull_planes()[spheres.link[s]]
            want[i] |= bool(len(local)) and bool((plane_distance(planes, local) <= 0.01).any())
    spheres_only = GeometricBackend(GeometricBackendConfig(exact_margin=None))
    spheres_only.set_check_cloud(cloud)
    assert 0 < want.sum() < spheres_only.check(q).sum()  # the hulls let some sphere hits go, not all
    np.testing.assert_array_equal(backend.check(q), want)


def test_inner_balls_lie_inside_their_hulls():
    link, centre, radius = hull_inner_balls()
    assert len(set(link.tolist())) == len(link_hull_planes()) - 1  # every moving link
    rng = np.random.default_rng(0)
    d = rng.normal(size=(200, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    for lk, c, r in zip(link, centre, radius, strict=True):
        assert r > 0 and plane_distance(link_hull_planes()[lk], c + r * d).max() <= 1e-9


def test_a_dense_cloud_is_checked_as_brute_force_says():
    """A dense block (most refusals are decided by voxels wholly inside a link's inner ball) and a non-finite
    configuration: the check equals "an observed point within 1 cm of a link's hull"."""
    backend, q, cloud, frames = _block_scene(5, 30000)
    want = np.zeros(len(q), dtype=bool)
    for i in range(len(q)):
        for lk, planes in link_hull_planes().items():
            if lk == LINK_FRAMES.index("panda_link0"):
                continue
            local = (cloud - frames[i, lk, :3, 3]) @ frames[i, lk, :3, :3]
            want[i] |= bool((plane_distance(planes, local) <= 0.01).any())
    assert 0 < want.sum() < len(q)
    np.testing.assert_array_equal(backend.check(q), want)
    bad = q[:3].copy()
    bad[1, 2] = np.nan
    assert backend.check(bad).tolist() == [want[0], True, want[2]]

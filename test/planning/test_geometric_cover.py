"""The hard check sees every point on a link: its prefilter spheres cover the link hulls, grown by the margin."""

import numpy as np
from scipy.spatial import ConvexHull

from latent_planner_ros.planning.geometric_backend import GeometricBackend
from latent_planner_ros.robot.limits import Q_READY
from latent_planner_ros.robot.link_hulls import hull_cover_spheres, link_vertices
from latent_planner_ros.robot.panda import LINK_FRAMES
from latent_planner_ros.robot.torch_fk import TorchFK


def _hull_surface(vertices: np.ndarray, n: int, rng: np.random.Generator) -> np.ndarray:
    tri = vertices[ConvexHull(vertices).simplices]
    area = 0.5 * np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
    idx = rng.choice(len(tri), n, p=area / area.sum())
    a, b = rng.random((2, n, 1))
    flip = a + b > 1
    a, b = np.where(flip, 1 - a, a), np.where(flip, 1 - b, b)
    return tri[idx, 0] + a * (tri[idx, 1] - tri[idx, 0]) + b * (tri[idx, 2] - tri[idx, 0])


def test_the_cover_spheres_contain_every_hull_surface_point():
    link, centre, radius = hull_cover_spheres()
    rng = np.random.default_rng(11)  # other samples than the fit's
    for name, vertices in link_vertices().items():
        if name == "panda_link0":
            continue
        sel = link == LINK_FRAMES.index(name)
        pts = _hull_surface(vertices, 3000, rng)
        outside = (np.linalg.norm(pts[:, None] - centre[sel][None], axis=2) - radius[sel][None]).min(axis=1)
        assert outside.max() <= 0.0, (name, outside.max())


def test_a_point_on_a_link_hull_where_the_sphere_model_has_a_gap_is_refused():
    """panda_link5's hull reaches up to 9 cm beyond the sphere model's spheres: points there were let through."""
    backend = GeometricBackend()
    frames = TorchFK().frames_np(Q_READY[None])[0]
    li = LINK_FRAMES.index("panda_link5")
    spheres = backend.spheres
    sel = spheres.link == li
    pts = _hull_surface(link_vertices()["panda_link5"], 4000, np.random.default_rng(3))
    gap = (np.linalg.norm(pts[:, None] - spheres.centre[sel][None], axis=2) - spheres.radius[sel][None]).min(axis=1)
    worst = pts[np.argsort(gap)[-5:]]  # the hull points farthest outside the sphere model
    assert gap.max() > 0.03
    for p in worst:
        world = frames[li, :3, :3] @ p + frames[li, :3, 3]
        backend.set_scene(world[None])
        assert backend.check(Q_READY[None])[0], p

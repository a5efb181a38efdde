"""Exact per-link labels against independent checks (coal distances, bounding spheres, hand-made cases)."""

import coal
import numpy as np

from latent_planner_ros.data.labels import CollisionLabeler, link_poses
from latent_planner_ros.data.link_geometry import LABEL_LINKS, link_geometry
from latent_planner_ros.data.obstacle_geometry import coal_geometry
from latent_planner_ros.data.obstacles import Box, Capsule, Cylinder, Mesh, Sphere, distance_below
from latent_planner_ros.data.queries import QuerySamplerConfig, sample_queries
from latent_planner_ros.data.scene import Scene
from latent_planner_ros.data.scene_generator import generate_scene
from latent_planner_ros.robot.limits import Q_READY
from latent_planner_ros.robot.panda import load_panda
from latent_planner_ros.robot.sampler import FeasibleSampler

IDENTITY = (0.0, 0.0, 0.0, 1.0)


def _distance_labels(scene, q):
    """Independent reference: per link, min coal distance over (part, obstacle) <= 0, without prefilter."""
    links = link_geometry()
    objects = [coal_geometry(o) for o in scene.obstacles]
    poses = link_poses(q)
    dist = np.full((len(q), len(LABEL_LINKS)), np.inf)
    req = coal.DistanceRequest()
    for i in range(len(q)):
        for l_idx, parts in enumerate(links.parts):
            for geom, place in parts:
                t = poses[i, l_idx] @ place
                for g_o, tf_o in objects:
                    res = coal.DistanceResult()
                    d = coal.distance(geom, coal.Transform3s(t[:3, :3], t[:3, 3]), g_o, tf_o, req, res)
                    dist[i, l_idx] = min(dist[i, l_idx], d)
    return dist


def test_labels_agree_with_coal_distances_on_random_near_cases(rng):
    sampler = FeasibleSampler(rng)
    pool = sampler.sample(3000)
    cfg = QuerySamplerConfig(n_uniform=10, n_near=30, candidates=1500)
    checked = positives = 0
    for family in ("train", "heldout"):
        scene = generate_scene(rng, family)
        q, _ = sample_queries(scene, pool, rng, cfg)
        labels = CollisionLabeler(scene).label(q)
        dist = _distance_labels(scene, q)
        clear = np.abs(dist) > 1e-4  # skip grazing contacts, where the two queries may round differently
        np.testing.assert_array_equal(labels[clear], (dist <= 0)[clear])
        checked += int(clear.sum())
        positives += int(labels.sum())
    assert positives > 0 and checked > 100


def test_far_links_are_free_and_pose_summary_spheres_contain_the_links():
    links = link_geometry()
    for geoms, c, r, surf in zip(
        links.parts, links.sphere_centres, links.sphere_radii, links.surface_points, strict=True
    ):
        assert np.all(np.linalg.norm(surf - c, axis=1) <= r + 1e-9)
        assert len(geoms) >= 1
    far = Scene((Box((0.6, 0.55, 0.05), IDENTITY, (0.05, 0.05, 0.05)),))
    assert not CollisionLabeler(far).label(Q_READY[None]).any()


def test_a_small_box_between_the_open_fingers_is_free_a_wider_one_hits_the_fingers():
    tcp = load_panda().fk(Q_READY).translation
    small = Scene((Box(tuple(tcp), IDENTITY, (0.01, 0.01, 0.01)),))
    assert not CollisionLabeler(small).label(Q_READY[None]).any()
    scene = Scene((Box(tuple(tcp), IDENTITY, (0.06, 0.06, 0.01)),))
    hit = CollisionLabeler(scene).label(Q_READY[None])[0]
    names = {n for n, h in zip(LABEL_LINKS, hit, strict=True) if h}
    assert names and names <= {"panda_hand", "panda_leftfinger", "panda_rightfinger", "panda_link7"}
    assert {"panda_leftfinger", "panda_rightfinger"} & names


def test_a_link_inside_a_big_box_is_in_collision():
    elbow = link_poses(Q_READY[None])[0, LABEL_LINKS.index("panda_link4"), :3, 3]
    scene = Scene((Box(tuple(elbow), IDENTITY, (0.3, 0.3, 0.3)),))
    assert CollisionLabeler(scene).label(Q_READY[None])[0, LABEL_LINKS.index("panda_link4")]


def test_contact_points_lie_where_the_arm_meets_the_obstacle():
    """A box around the hand at the ready pose: contacts near the hand, inside the box; none for a free pose."""
    hand = load_panda().fk(Q_READY, "panda_hand").translation
    box = Box(tuple(float(x) for x in hand), IDENTITY, (0.05, 0.05, 0.05))
    labeler = CollisionLabeler(Scene(obstacles=(box,)))
    far = Q_READY.copy()
    far[0] += 2.5  # swing the arm away from the box
    assert labeler.label(np.stack([Q_READY, far])).any(1).tolist() == [True, False]
    touching, free = labeler.contact_points(np.stack([Q_READY, far]))
    assert len(touching) > 0 and free.shape == (0, 3)
    assert np.all(np.abs(touching - hand) <= 0.05 + 0.02)  # in the box (coal's contact lies in the overlap)


def _shapes():
    tilt = (0.3, 0.2, 0.1, 0.927)  # a rotation about a skew axis (normalised by the shapes)
    norm = float(np.linalg.norm(tilt))
    tilt = tuple(v / norm for v in tilt)
    mesh_vertices = np.array([[0.3, -0.3, 0.2], [0.5, -0.3, 0.2], [0.4, -0.1, 0.2], [0.4, -0.2, 0.45]])
    return (
        Box((0.45, 0.25, 0.35), tilt, (0.08, 0.03, 0.2)),
        Cylinder((0.35, -0.35, 0.4), IDENTITY, 0.04, 0.4),  # tall and thin, as LSPP's
        Cylinder((0.6, 0.0, 0.6), tilt, 0.05, 0.15),
        Sphere((0.2, 0.4, 0.7), 0.06),
        Capsule((0.55, -0.1, 0.25), tilt, 0.03, 0.12),
        Mesh(mesh_vertices, np.array([[0, 1, 2], [0, 1, 3], [1, 2, 3], [0, 2, 3]])),
    )


def test_distance_below_is_the_exact_distance_of_each_primitive(rng):
    """obstacles.distance_below against coal's distance from a tiny ball: equal for primitives, below for meshes."""
    ball = coal.Sphere(1e-6)
    for shape in _shapes():
        geom, tf = coal_geometry(shape)
        centre = np.asarray(getattr(shape, "position", (0.4, -0.2, 0.3)))
        pts = np.vstack([centre, centre + rng.uniform(-0.3, 0.3, size=(200, 3))])
        bound = distance_below(shape, pts)
        ref = np.array([
            max(coal.distance(ball, coal.Transform3s(np.eye(3), p), geom, tf, coal.DistanceRequest(),
                              coal.DistanceResult()), 0.0)
            for p in pts
        ])  # fmt: skip
        assert np.all(bound <= ref + 1e-5), type(shape).__name__
        if not isinstance(shape, Mesh):
            np.testing.assert_allclose(bound, ref, atol=1e-5, err_msg=type(shape).__name__)
        assert (bound == 0).any() and (bound > 0.05).any()  # points inside and well outside


def test_labels_with_every_primitive_agree_with_coal_distances(rng):
    """The shape filter only skips pairs that cannot touch: labels equal coal's distances near every primitive."""
    scene = Scene(_shapes())
    q = Q_READY + rng.normal(0.0, 0.6, size=(150, 7))
    labels = CollisionLabeler(scene).label(q)
    dist = _distance_labels(scene, q)
    clear = np.abs(dist) > 1e-4
    np.testing.assert_array_equal(labels[clear], (dist <= 0)[clear])
    assert labels.sum() > 10 and (~labels).sum() > 10

"""LSPP cylinders: validation, geometry against the arm, and the balanced exact-label dataset."""

import numpy as np
import pytest

from latent_planner_ros.data.cylinder_dataset import CylinderData, generate, label_pairs
from latent_planner_ros.data.cylinders import CylinderRanges, cylinder_obstacle, cylinder_scene, validate_cylinders
from latent_planner_ros.data.labels import CollisionLabeler
from latent_planner_ros.robot.limits import Q_READY
from latent_planner_ros.robot.panda import load_panda


def test_validation_names_the_problem():
    assert validate_cylinders([]).shape == (0, 4)
    with pytest.raises(ValueError, match="shape"):
        validate_cylinders(np.zeros((2, 3)))
    with pytest.raises(ValueError, match="finite"):
        validate_cylinders([[0.5, 0.0, np.nan, 0.05]])
    with pytest.raises(ValueError, match="positive"):
        validate_cylinders([[0.5, 0.0, 0.3, 0.0]])


def test_a_cylinder_stands_on_the_table():
    c = cylinder_obstacle([0.4, -0.2, 0.6, 0.05])
    assert c.position == pytest.approx((0.4, -0.2, 0.3))
    assert c.half_length == pytest.approx(0.3) and c.radius == pytest.approx(0.05)


def test_a_cylinder_under_the_hand_collides_and_one_far_away_does_not():
    tcp = load_panda().fk(Q_READY).translation
    under = [tcp[0], tcp[1], tcp[2] + 0.05, 0.04]  # up to 5 cm above the TCP, right below the hand
    beside = [tcp[0], tcp[1] + 0.5, tcp[2] + 0.05, 0.04]
    hits = CollisionLabeler(cylinder_scene(np.array([under]))).label(Q_READY[None]).any()
    misses = CollisionLabeler(cylinder_scene(np.array([beside]))).label(Q_READY[None]).any()
    assert hits and not misses
    low = [tcp[0], tcp[1], 0.2 * tcp[2], 0.04]  # short: below the hand
    assert not CollisionLabeler(cylinder_scene(np.array([low]))).label(Q_READY[None]).any()


def test_sampled_cylinders_are_in_range():
    o = CylinderRanges().sample(np.random.default_rng(0), 500)
    dist = np.hypot(o[:, 0], o[:, 1])
    assert dist.min() >= 0.3 and dist.max() <= 0.8
    assert o[:, 2].min() >= 0.1 and o[:, 3].max() <= 0.1


def test_the_dataset_is_balanced_and_its_labels_are_exact(tmp_path):
    data = generate(400, seed=3, pool=2000, progress=False)
    assert len(data) == 400 and data.c.mean() == pytest.approx(0.5)
    idx = np.random.default_rng(0).choice(400, 60, replace=False)
    assert np.array_equal(label_pairs(data.q[idx], data.o[idx]), data.c[idx])
    back = CylinderData.load(data.save(tmp_path / "d.npz"))
    assert np.array_equal(back.q, data.q) and np.array_equal(back.c, data.c)

"""The target of a grasp goal: the object between the fingers is set aside, its support and the rest stay."""

import numpy as np
import pytest

from latent_planner_ros.perception.grasp_target import TargetBox, closing_mask, split_target


def _grid(lo, hi, step=0.004):
    axes = [np.arange(a, b + 1e-9, step) if b > a else np.array([a]) for a, b in zip(lo, hi, strict=True)]
    return np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, 3)


def _box_surface(lo, hi, step=0.004):
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    faces = []
    for axis in range(3):
        for v in (lo[axis], hi[axis]):
            a, b = lo.copy(), hi.copy()
            a[axis] = b[axis] = v
            faces.append(_grid(a, b, step))
    return np.unique(np.round(np.concatenate(faces), 6), axis=0)


# a 4 x 3 x 8 cm box standing on a board (top at z = 0.30), a side grasp from -x: hand z = +x, fingers along y
BOARD_TOP = 0.30
OBJECT = _box_surface((0.58, -0.015, BOARD_TOP), (0.62, 0.015, BOARD_TOP + 0.08))
OBJECT = OBJECT[OBJECT[:, 2] > BOARD_TOP]  # the bottom face is not seen
BOARD = _grid((0.45, -0.25, BOARD_TOP), (0.75, 0.25, BOARD_TOP))
BOARD_FRONT = _grid((0.45, -0.25, BOARD_TOP - 0.02), (0.45, 0.25, BOARD_TOP))
WALL = _grid((0.8, -0.25, BOARD_TOP), (0.8, 0.25, BOARD_TOP + 0.2))  # the back panel, 18 cm behind the object
TCP = np.array([0.60, 0.0, BOARD_TOP + 0.04])
HAND = np.array([[0.0, 0.0, 1.0], [0.0, 1.0, 0.0], [-1.0, 0.0, 0.0]])  # columns: x down, y = y, z = +x


def _cloud(rng=None):
    cloud = np.concatenate([BOARD, BOARD_FRONT, WALL, OBJECT])
    if rng is not None:
        cloud = cloud + rng.normal(0.0, 0.001, cloud.shape)
    is_object = np.zeros(len(cloud), dtype=bool)
    is_object[-len(OBJECT) :] = True
    return cloud.astype(np.float32), is_object


def test_hand_frame_is_a_rotation():
    assert np.allclose(HAND.T @ HAND, np.eye(3)) and np.isclose(np.linalg.det(HAND), 1.0)


@pytest.mark.parametrize("noisy", [False, True])
def test_box_on_a_board_is_the_target_and_nothing_else(noisy):
    cloud, is_object = _cloud(np.random.default_rng(0) if noisy else None)
    split = split_target(cloud, TCP, HAND)
    assert not (split.mask & ~is_object).any(), "a board, edge or wall point was set aside"
    above = is_object & (cloud[:, 2] > BOARD_TOP + 0.01)
    assert split.mask[above].all(), "an object point above the support margin was kept as an obstacle"
    assert split.support_z is not None and abs(split.support_z - BOARD_TOP - 0.005) < 0.003
    assert len(split.obstacles) + len(split.target) == len(cloud)
    assert split.obstacles.dtype == cloud.dtype
    assert str(split.count) in split.report and "closing region" in split.report


def test_no_points_between_the_fingers_sets_nothing_aside():
    cloud, _ = _cloud()
    split = split_target(cloud, TCP + np.array([0.0, 0.3, 0.0]), HAND)
    assert split.count == 0 and len(split.obstacles) == len(cloud) and "no target" in split.report


def test_growth_stops_at_the_reach_radius():
    tall = _box_surface((0.58, -0.015, BOARD_TOP), (0.62, 0.015, BOARD_TOP + 0.4))
    split = split_target(tall, TCP, HAND)
    assert 0 < split.count < len(tall)
    assert np.linalg.norm(split.target - TCP, axis=1).max() <= 0.07 + 1e-9


def test_caller_radius_and_box():
    cloud, is_object = _cloud()
    by_radius = split_target(cloud, TCP, HAND, radius=0.03)
    assert np.array_equal(by_radius.mask, np.linalg.norm(cloud - TCP, axis=1) <= 0.03)
    box = TargetBox(TCP + [0.0, 0.0, 0.002], np.eye(3), np.array([0.025, 0.02, 0.0395]))
    by_box = split_target(cloud, TCP, HAND, box=box)
    assert by_box.mask[is_object & (cloud[:, 2] > BOARD_TOP + 0.004)].all() and not by_box.mask[~is_object].any()
    with pytest.raises(ValueError, match="not both"):
        split_target(cloud, TCP, HAND, radius=0.03, box=box)


def test_closing_region_lies_between_the_fingers():
    inside = TCP + HAND @ np.array([0.0, 0.035, 0.0])
    past_finger = TCP + HAND @ np.array([0.0, 0.06, 0.0])
    beyond_tips = TCP + HAND @ np.array([0.0, 0.0, 0.03])
    assert closing_mask(np.stack([inside, past_finger, beyond_tips]), TCP, HAND, 0.005).tolist() == [
        True,
        False,
        False,
    ]

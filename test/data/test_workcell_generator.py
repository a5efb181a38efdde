"""Workcell scenes: every family stays within reach and clear of the base, regions are free space, the
held-out split makes what the train split never does, and scenes are deterministic in the seed."""

import math

import coal
import numpy as np
import pytest

from latent_planner_ros.data.obstacle_geometry import coal_geometry
from latent_planner_ros.data.workcell_generator import (
    HELDOUT_YAW_DEG,
    SPLITS,
    TRAIN_YAW_DEG,
    WORKCELL_FAMILIES,
    generate_workcell,
    generate_workcell_layout,
    keeps_clear_of_base,
    within_reach_bounds,
)

SEEDS = range(4)


def _layouts(family, split):
    return [generate_workcell_layout(np.random.default_rng(s), family, s, split) for s in SEEDS]


def _overlaps(region, obstacles, shrink=0.01) -> bool:
    box = coal.Box(*(2 * (np.asarray(region.half_extents) - shrink)))
    tf = coal.Transform3s(region.axes, np.asarray(region.centre))
    request, result = coal.CollisionRequest(), coal.CollisionResult()
    for o in obstacles:
        g, t = coal_geometry(o)
        result.clear()
        if coal.collide(box, tf, g, t, request, result):
            return True
    return False


@pytest.mark.parametrize("split", SPLITS)
@pytest.mark.parametrize("family", WORKCELL_FAMILIES)
def test_scenes_within_reach_and_clear_of_the_base(family, split):
    for cell in _layouts(family, split):
        scene = cell.scene
        assert scene.family == family and len(scene.obstacles) >= 2
        assert within_reach_bounds(scene.obstacles) and keeps_clear_of_base(scene.obstacles)
        (piece,) = cell.furniture
        assert cell.regions and cell.surfaces
        for r in cell.regions:
            assert np.allclose(r.axes.T @ r.axes, np.eye(3)) and min(r.half_extents) > 0
            if r.kind != "under":  # the space under a shelf holds the objects to pick
                assert not _overlaps(r, piece.parts), (family, split, r)
        for s in cell.surfaces:
            assert math.isclose(np.linalg.norm(s.normal), 1.0, abs_tol=1e-9)
        if family == "mixed":
            assert scene.n_objects >= 2


def test_the_keep_out_test_sees_an_obstacle_at_the_base():
    from latent_planner_ros.data.workcell_furniture import slab

    assert not keeps_clear_of_base([slab((-0.35, -0.5, 0.0), (-0.25, 0.5, 0.8))])  # a wall 25 cm behind
    assert keeps_clear_of_base([slab((-0.45, -0.5, 0.0), (-0.35, 0.5, 0.8))])


def test_furniture_stands_all_around_the_base():
    azimuths = [
        math.atan2(c.furniture[0].anchor[1], c.furniture[0].anchor[0])
        for f in WORKCELL_FAMILIES
        for c in _layouts(f, "train")
    ]
    assert np.histogram(azimuths, bins=4, range=(-math.pi, math.pi))[0].min() > 0


@pytest.mark.parametrize("split", SPLITS)
def test_opening_turn_depends_on_the_split(split):
    for family in WORKCELL_FAMILIES[:-1]:
        for cell in _layouts(family, split):
            piece = cell.furniture[0]
            to_base = -np.asarray(piece.anchor[:2]) / np.linalg.norm(piece.anchor[:2])
            turn = math.degrees(math.acos(np.clip(np.dot(piece.front[:2], to_base), -1, 1)))
            if split == "train":
                assert turn <= TRAIN_YAW_DEG + 1e-6
            else:
                assert HELDOUT_YAW_DEG[0] - 1e-6 <= turn <= HELDOUT_YAW_DEG[1] + 1e-6


def test_heldout_variants_are_outside_the_train_ranges():
    def bars(cell):  # half thickness [m] of each bar
        return [o.half_extents[0] if hasattr(o, "half_extents") else o.radius for o in cell.scene.obstacles]

    train_bins = [len(c.regions) for c in _layouts("bin", "train")]
    held_bins = [len(c.regions) for c in _layouts("bin", "heldout")]
    assert max(train_bins) <= 2 and min(held_bins) >= 3
    assert max(max(bars(c)) for c in _layouts("cage", "train")) <= 0.015
    assert min(min(bars(c)) for c in _layouts("cage", "heldout")) >= 0.016
    train_under = [c.regions[0].centre[2] + c.regions[0].half_extents[2] for c in _layouts("undershelf", "train")]
    held_under = [c.regions[0].centre[2] + c.regions[0].half_extents[2] for c in _layouts("undershelf", "heldout")]
    assert min(train_under) >= 0.25 and max(held_under) <= 0.25
    for cell in _layouts("bookshelf", "heldout"):  # one thin (1-2 cm) and one thick (3-5 cm) panel kind
        thick = sorted({round(2 * min(o.half_extents), 3) for o in cell.scene.obstacles})
        assert thick[0] <= 0.02 and thick[-1] >= 0.03
    for cell in _layouts("bookshelf", "train"):
        thick = [2 * min(o.half_extents) for o in cell.scene.obstacles]
        assert max(thick) <= 0.02 * 1.1 or min(thick) >= 0.03 * 0.9


def test_deterministic_in_the_seed_and_split():
    a = generate_workcell(np.random.default_rng(7), "mixed", 7).to_dict()
    assert a == generate_workcell(np.random.default_rng(7), "mixed", 7).to_dict()
    assert a != generate_workcell(np.random.default_rng(7), "mixed", 7, split="heldout").to_dict()
    with pytest.raises(ValueError, match="unknown workcell family"):
        generate_workcell(np.random.default_rng(0), "kitchen")

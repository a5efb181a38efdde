"""The arm's ground-truth clearance to the scenario objects (published as sim/min_distance)."""

from __future__ import annotations

import numpy as np
import pytest

from sim_bridge.scenario import scenario_from_dict
from sim_bridge.sim import DISTANCE_CUTOFF_M


def plate_below_hand(make_sim, top_z: float, x: float = 0.307, y: float = 0.0):
    """A sim whose only object is a 20 x 20 x 2 cm plate with its top face at top_z [m] (the arm at the ready
    pose, its fingertips near (0.31, 0, 0.48))."""
    scenario = scenario_from_dict(
        {
            "name": "plate",
            "objects": [
                {"name": "plate", "type": "box", "half_extents": [0.1, 0.1, 0.01], "position": [x, y, top_z - 0.01]}
            ],
        }
    )
    return make_sim(scenario)


def test_distance_follows_the_object_and_names_it(make_sim):
    near = plate_below_hand(make_sim, 0.44)
    d_near, name = near.nearest_object()
    d_far, _ = plate_below_hand(make_sim, 0.41).nearest_object()
    assert name == "plate"
    assert 0.0 < d_near < 0.06
    assert d_far - d_near == pytest.approx(0.03, abs=1e-6)  # lowering the plate by 3 cm adds 3 cm
    fingertips_z = 0.44 + d_near
    assert near.get_state().tcp_position[2] - 0.03 < fingertips_z < near.get_state().tcp_position[2]


def test_overlap_is_negative_and_a_contact(make_sim):
    sim = plate_below_hand(make_sim, 0.50)  # the plate cuts through the fingers
    d, name = sim.nearest_object()
    assert d < 0.0 and name == "plate"
    assert sim.in_collision()


def test_cutoff_and_no_objects(make_sim):
    sim = plate_below_hand(make_sim, 0.02, x=0.7, y=0.5)  # on the table, far from the arm
    assert sim.nearest_object()[0] > 0.2
    assert sim.nearest_object(cutoff=0.05) == (0.05, "")
    assert make_sim("empty").nearest_object() == (DISTANCE_CUTOFF_M, "")


def test_conveyor_clearance_is_positive_at_the_ready_pose(make_sim):
    sim = make_sim("conveyor", seed=0)
    d0, _ = sim.nearest_object()
    sim.step(250)  # 0.5 s: the objects move, the arm holds
    d1, name = sim.nearest_object()
    assert 0.05 < d0 <= DISTANCE_CUTOFF_M and 0.05 < d1 <= DISTANCE_CUTOFF_M
    assert name in {"belt", "target", "obstacle", ""}
    assert np.isfinite(d1)

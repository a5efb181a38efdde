"""Scenario objects converted to the project's obstacle primitives."""

from __future__ import annotations

import numpy as np
import pytest

from latent_planner_ros.data.obstacles import Box, Mesh, Sphere, bounding_sphere
from sim_bridge.obstacles import scenario_obstacles
from sim_bridge.scenario_files import load_scenario


def test_every_object_becomes_an_obstacle_of_the_same_shape():
    for seed in range(5):
        scenario = load_scenario("tabletop", seed=seed)
        for obj, obstacle in zip(scenario.objects, scenario_obstacles(scenario), strict=True):
            assert type(obstacle).__name__.lower() == obj.type
            centre, radius = bounding_sphere(obstacle)
            if isinstance(obstacle, Mesh):
                assert obstacle.vertices[:, 2].min() == pytest.approx(0.0, abs=1e-9)  # rests on the table
                distance = np.linalg.norm(obstacle.vertices - obj.position, axis=1)
                assert distance.max() == pytest.approx(obj.bounding_radius())  # a rigid move of the object's mesh
            else:
                np.testing.assert_allclose(centre, obj.position)
                assert radius == pytest.approx(obj.bounding_radius())


def test_moving_objects_are_taken_at_time_t():
    scenario = load_scenario("conveyor", seed=0)
    now, later = scenario_obstacles(scenario, 0.0), scenario_obstacles(scenario, 2.0)
    belt, target = now[0], now[1]
    assert isinstance(belt, Box) and later[0] == belt
    moved = np.subtract(later[1].position, target.position)
    assert moved[1] == pytest.approx(0.1) or moved[1] < -0.5  # 2 s at 0.05 m/s, or wrapped round
    assert not isinstance(target, Sphere)

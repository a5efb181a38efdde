"""Procedural scenes: schema, JSON round trip, placement ranges."""

import numpy as np
import pytest

from latent_planner_ros.data.obstacle_geometry import triangle_mesh
from latent_planner_ros.data.obstacles import Box, Sphere, obstacle_from_dict, transformed
from latent_planner_ros.data.scene import Scene
from latent_planner_ros.data.scene_generator import SceneGeneratorConfig, generate_scene


@pytest.mark.parametrize("family", ["train", "heldout"])
def test_scenes_round_trip_through_json(rng, family):
    for _ in range(10):
        scene = generate_scene(rng, family)
        back = Scene.from_json(scene.to_json())
        assert back == scene
        assert back.to_dict() == scene.to_dict()


def test_schema_types_and_families(rng):
    train = [generate_scene(rng, "train") for _ in range(20)]
    held = [generate_scene(rng, "heldout") for _ in range(20)]
    kinds = {o["type"] for s in train for o in s.to_dict()["obstacles"]}
    assert kinds == {"box", "cylinder", "sphere", "capsule", "mesh"}
    # held-out objects are composites of several parts
    assert all(len(s.obstacles) > s.n_objects for s in held)
    cfg = SceneGeneratorConfig()
    for s in train + held:
        assert cfg.n_objects[0] - 1 <= s.n_objects <= cfg.n_objects[1]  # one oversized object may be dropped


def test_objects_stay_in_reach_on_the_table_and_clear_of_the_base(rng):
    cfg = SceneGeneratorConfig()
    for _ in range(20):
        s = generate_scene(rng, "heldout" if rng.random() < 0.5 else "train", cfg)
        for o in s.obstacles:
            v, _ = triangle_mesh(o)
            assert v[:, 2].min() >= -cfg.sink_range[1] - 1e-6
            assert np.linalg.norm(v[:, :2], axis=1).min() > cfg.base_clearance - 1e-6
            assert v[:, 2].max() < 0.8


def test_bad_obstacles_are_refused_with_a_reason():
    with pytest.raises(ValueError, match="half_extents"):
        obstacle_from_dict({"type": "box", "position": [0, 0, 0], "half_extents": [0.1, -1, 0.1]})
    with pytest.raises(ValueError, match="radius"):
        obstacle_from_dict({"type": "sphere", "position": [0, 0, 0]})
    with pytest.raises(ValueError, match="unknown obstacle type"):
        obstacle_from_dict({"type": "cone", "position": [0, 0, 0]})
    with pytest.raises(ValueError, match="obstacle 1"):
        Scene.from_dict({"obstacles": [{"type": "sphere", "position": [0, 0, 0], "radius": 1}, {"type": "x"}]})


def test_transformed_moves_the_surface_rigidly(rng):
    box = Box((0.1, 0.2, 0.3), (0.0, 0.0, 0.0, 1.0), (0.1, 0.05, 0.02))
    angle = 0.7
    rot = np.array([[np.cos(angle), -np.sin(angle), 0], [np.sin(angle), np.cos(angle), 0], [0, 0, 1]])
    t = np.array([0.5, -0.1, 0.0])
    moved = transformed(box, rot, t)
    np.testing.assert_allclose(triangle_mesh(moved)[0], triangle_mesh(box)[0] @ rot.T + t, atol=1e-12)
    assert transformed(Sphere((0, 0, 0), 0.1), rot, t).position == pytest.approx(tuple(t))

"""Scenario dataclasses, schema validation, motions and the seeded generators."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from sim_bridge.conveyor import ConveyorParams, conveyor
from sim_bridge.placement import random_convex_mesh, resting_height
from sim_bridge.scenario import Motion, ScenarioError, scenario_from_dict
from sim_bridge.tabletop import TabletopParams, tabletop

BOX = {"name": "b", "type": "box", "half_extents": [0.05, 0.05, 0.1], "position": [0.5, 0.0, 0.1]}


@pytest.mark.parametrize(
    ("patch", "field"),
    [
        ({"half_extents": [0.1, -1, 0.1]}, "objects[0].half_extents"),
        ({"half_extents": [0.1, 0.1]}, "objects[0].half_extents"),
        ({"type": "torus"}, "objects[0].type"),
        ({"radius": 0.1}, "objects[0].radius"),
        ({"position": [0, "a", 0]}, "objects[0].position"),
        ({"quaternion_xyzw": [0, 0, 0, 0]}, "objects[0].quaternion_xyzw"),
        ({"colour": [1, 0, 0, 1]}, "objects[0].colour"),
        ({"rgba": [2, 0, 0, 1]}, "objects[0].rgba"),
        ({"motion": {"velocity": [0, 0.1, 0], "lower": [0, -1, 0], "upper": [0, -0.5, 0]}}, "objects[0].motion"),
        ({"motion": {"velocity": [0, 0.1, 0], "lower": [0, 0, 0], "upper": [1, 1, 1], "mode": "loop"}}, "mode"),
    ],
)
def test_bad_object_is_refused_naming_the_field(patch, field):
    with pytest.raises(ScenarioError, match=field.replace("[", r"\[").replace("]", r"\]")):
        scenario_from_dict({"name": "x", "objects": [{**BOX, **patch}]})


def test_bad_target_and_duplicates_are_refused():
    with pytest.raises(ScenarioError, match=r"target\.object"):
        scenario_from_dict({"objects": [BOX], "target": {"position": [0, 0, 0.1], "object": "nope"}})
    with pytest.raises(ScenarioError, match="duplicate"):
        scenario_from_dict({"objects": [BOX, BOX]})
    with pytest.raises(ScenarioError, match=r"objects\[0\]\.vertices"):
        flat = {"name": "m", "type": "mesh", "position": [0.5, 0, 0.1], "faces": [[0, 1, 2]] * 4}
        scenario_from_dict({"objects": [{**flat, "vertices": [[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]]}]})


def test_round_trip_through_dict():
    scenario = tabletop(np.random.default_rng(3))
    again = scenario_from_dict(scenario.to_dict())
    assert again == scenario


def test_wrap_and_bounce_motion():
    wrap = Motion(velocity=(0.0, 0.1, 0.0), lower=(0.5, -0.5, 0.1), upper=(0.5, 0.5, 0.1), mode="wrap")
    start = (0.5, 0.4, 0.1)
    np.testing.assert_allclose(wrap.position(start, 0.5), [0.5, 0.45, 0.1])
    np.testing.assert_allclose(wrap.position(start, 2.0), [0.5, -0.4, 0.1])  # went past 0.5, reappeared at -0.5
    bounce = Motion(velocity=(0.0, 0.1, 0.0), lower=(0.5, -0.5, 0.1), upper=(0.5, 0.5, 0.1), mode="bounce")
    np.testing.assert_allclose(bounce.position(start, 3.0), [0.5, 0.3, 0.1])  # up to 0.5, back by 0.2
    ys = [bounce.position(start, t)[1] for t in np.linspace(0, 30, 301)]
    assert min(ys) >= -0.5 - 1e-9 and max(ys) <= 0.5 + 1e-9
    assert np.max(np.abs(np.diff(ys))) <= 0.1 * 0.1 + 1e-9  # continuous: never jumps


def test_tabletop_is_seeded_and_within_its_parameters():
    a, b = tabletop(np.random.default_rng(5)), tabletop(np.random.default_rng(5))
    assert a == b
    counts, kinds = [], set()
    for seed in range(30):
        s = tabletop(np.random.default_rng(seed))
        counts.append(len(s.objects))
        for obj in s.objects:
            kinds.add(obj.type)
            assert 0.3 - 1e-9 <= obj.position[0] <= 0.8 + 1e-9 and -0.5 - 1e-9 <= obj.position[1] <= 0.5 + 1e-9
            assert np.hypot(*obj.position[:2]) - obj.bounding_radius() >= 0.2 - 1e-9
    assert min(counts) >= 4 and max(counts) <= 8 and len(set(counts)) > 2
    assert kinds == {"box", "cylinder", "sphere", "capsule", "mesh"}


def test_objects_rest_on_the_table():
    """The lowest point of every object is at z = 0 (checked on sampled surface points)."""
    for seed in range(10):
        for obj in tabletop(np.random.default_rng(seed)).objects:
            rot = Rotation.from_quat(obj.quaternion_xyzw).as_matrix()
            sizes = {k: getattr(obj, k) for k in ("half_extents", "radius", "half_length", "vertices")}
            assert obj.position[2] == pytest.approx(resting_height(obj.type, rot, sizes))
            if obj.type == "box":
                corners = np.array(np.meshgrid([-1, 1], [-1, 1], [-1, 1])).reshape(3, -1).T * obj.half_extents
                assert (corners @ rot.T)[:, 2].min() + obj.position[2] == pytest.approx(0.0, abs=1e-12)


def test_tabletop_params_are_validated():
    with pytest.raises(ScenarioError, match="min_objects"):
        TabletopParams(min_objects=9, max_objects=8)
    with pytest.raises(ScenarioError, match="types"):
        TabletopParams(types=("box", "teapot"))


def test_random_convex_mesh_faces_point_outwards(rng):
    mesh = random_convex_mesh(rng, np.array([0.05, 0.04, 0.03]))
    v, f = np.asarray(mesh["vertices"]), np.asarray(mesh["faces"])
    normals = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
    assert np.all(np.einsum("ij,ij->i", normals, v[f[:, 0]] - v.mean(axis=0)) > 0)


def test_conveyor_target_follows_its_object_and_keeps_the_gap():
    for seed in range(20):
        s = conveyor(np.random.default_rng(seed), ConveyorParams(speed=0.1))
        target, obstacle = s.object("target"), s.object("obstacle")
        assert obstacle.motion is not None and obstacle.motion.velocity == (0.0, 0.1, 0.0)
        loop = obstacle.motion.upper[1] - obstacle.motion.lower[1]
        assert target.motion.lower == (0.5, obstacle.motion.lower[1], target.position[2])  # one loop for both
        for t in np.linspace(0.0, 60.0, 601):  # several laps: the free belt between them stays >= min_gap
            d = (obstacle.position_at(t)[1] - target.position_at(t)[1]) % loop
            assert min(d, loop - d) - target.half_extents[1] - obstacle.half_extents[1] >= 0.15 - 1e-9
            for obj in (target, obstacle):
                assert abs(obj.position_at(t)[1]) + obj.half_extents[1] <= 0.6 + 1e-9
        for t in (0.0, 3.3, 17.0):
            pos, quat = s.target_pose_at(t)
            np.testing.assert_allclose(pos, target.position_at(t) + [0, 0, 0.025 + 0.1])
            np.testing.assert_allclose(quat, [1, 0, 0, 0])
    with pytest.raises(ScenarioError, match="mode"):
        ConveyorParams(mode="teleport")


def test_conveyor_bounce_reverses_the_whole_belt():
    """Objects on a reversing belt keep their distance (none passes through another) and stay on the belt."""
    times = np.linspace(0.0, 120.0, 2401)
    for seed in range(20):
        s = conveyor(np.random.default_rng(seed), ConveyorParams(speed=-0.08, mode="bounce"))
        target, obstacle = s.object("target"), s.object("obstacle")
        gaps = [target.position_at(t)[1] - obstacle.position_at(t)[1] for t in times]
        np.testing.assert_allclose(gaps, gaps[0], atol=1e-9)
        for obj in (target, obstacle):
            ys = np.array([obj.position_at(t)[1] for t in times])
            assert np.all(np.abs(ys) <= 0.6 - obj.half_extents[1] + 1e-9)
        ends = [np.abs(o.position_at(t)[1]) + o.half_extents[1] for o in (target, obstacle) for t in times]
        assert max(ends) == pytest.approx(0.6, abs=0.01)  # the belt reverses when an object reaches an end

"""Scenario sets: the schema round-trips, bad files are refused naming the field, generated problems are sound."""

import copy
import json

import numpy as np
import pytest

from latent_planner_ros.bench.problem_checks import direct_motion_collides
from latent_planner_ros.bench.scenario_generator import GeneratorConfig, generate_set
from latent_planner_ros.bench.scenarios import (
    DEFAULT_SET,
    CameraSpec,
    ScenarioError,
    ScenarioProblem,
    load_scenarios,
    save_scenarios,
    set_from_dict,
)
from latent_planner_ros.data.labels import CollisionLabeler
from latent_planner_ros.evaluation.path_check import PathJudge, densify_by_ee
from latent_planner_ros.planning.goal import Goal
from latent_planner_ros.robot.collision import CollisionChecker
from latent_planner_ros.robot.panda import load_panda


@pytest.fixture(scope="module")
def generated():
    return generate_set(GeneratorConfig(problems=2, seed=123), progress=False)


def test_round_trip(generated, tmp_path):
    path = save_scenarios(generated, tmp_path / "set.json")
    loaded = load_scenarios(path)
    assert loaded.name == generated.name and loaded.table and len(loaded.problems) == 2
    for a, b in zip(generated.problems, loaded.problems, strict=True):
        np.testing.assert_allclose(a.start, b.start, atol=1e-6)
        np.testing.assert_allclose(a.goal_position, b.goal_position, atol=1e-6)
        np.testing.assert_allclose(a.goal_quaternion_xyzw, b.goal_quaternion_xyzw, atol=1e-5)
        np.testing.assert_allclose(a.goal_q, b.goal_q, atol=1e-6)
        assert len(a.obstacles) == len(b.obstacles) > 0
        assert a.camera is not None and b.camera is not None
        np.testing.assert_allclose(a.camera.pose(), b.camera.pose(), atol=1e-5)
    assert save_scenarios(loaded, tmp_path / "again.json").read_text() == path.read_text()


def _valid() -> dict:
    return {
        "name": "mini",
        "table": True,
        "problems": [
            {
                "start": [0.0, -0.785, 0.0, -2.356, 0.0, 1.571, 0.785],
                "goal": {"position": [0.5, 0.0, 0.3], "quaternion_xyzw": [1.0, 0.0, 0.0, 0.0]},
                "obstacles": [
                    {"type": "box", "position": [0.5, 0.3, 0.1], "half_extents": [0.05, 0.05, 0.1]},
                    {"type": "cylinder", "position": [0.4, -0.3, 0.1], "radius": 0.03, "half_length": 0.1},
                    {"type": "sphere", "position": [0.6, 0.0, 0.05], "radius": 0.05},
                    {
                        "type": "mesh",
                        "vertices": [[0.7, 0, 0], [0.8, 0, 0], [0.7, 0.1, 0], [0.7, 0, 0.1]],
                        "faces": [[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]],
                    },
                ],
            }
        ],
    }


def test_the_documented_example_parses():
    s = set_from_dict(_valid())
    assert len(s.problems[0].obstacles) == 4 and s.problems[0].camera is None and s.problems[0].goal_q is None


def _set(d, path, value):
    *head, last = path
    for k in head:
        d = d[k]
    if value is _DELETE:
        del d[last]
    else:
        d[last] = value


_DELETE = object()
P = ("problems", 0)


@pytest.mark.parametrize(
    ("path", "value", "named"),
    [
        (("name",), "", "name"),
        (("table",), "yes", "table"),
        (("problems",), [], "problems"),
        ((*P, "start"), [0.0] * 6, "problems[0].start"),
        ((*P, "start"), [0.0, 0.0, 0.0, 0.5, 0.0, 1.0, 0.0], "problems[0].start: joint 4"),
        ((*P, "goal"), _DELETE, "problems[0].goal"),
        ((*P, "goal", "position"), _DELETE, "problems[0].goal.position"),
        ((*P, "goal", "quaternion_xyzw"), [0, 0, 1], "problems[0].goal.quaternion_xyzw"),
        ((*P, "goal", "quaternion_xyzw"), [0, 0, 2, 0], "problems[0].goal.quaternion_xyzw"),
        ((*P, "goal", "orientation"), [0, 0, 0, 1], "problems[0].goal: unknown field"),
        ((*P, "goal_q"), [0.0, "a", 0, 0, 0, 0, 0], "problems[0].goal_q"),
        ((*P, "obstacles", 0, "half_extents"), _DELETE, "problems[0].obstacles[0].half_extents"),
        ((*P, "obstacles", 0, "half_extents"), [0.1, -0.1, 0.1], "problems[0].obstacles[0].half_extents"),
        ((*P, "obstacles", 1, "radius"), 0.0, "problems[0].obstacles[1].radius"),
        ((*P, "obstacles", 2, "type"), "cone", "problems[0].obstacles[2].type"),
        ((*P, "obstacles", 2, "center"), [0, 0, 0], "problems[0].obstacles[2]: unknown field"),
        ((*P, "obstacles", 3, "faces"), [[0, 1, 9]] * 4, "problems[0].obstacles[3].faces"),
        ((*P, "camera"), {"eye": [1, 0, 1]}, "problems[0].camera.target"),
        ((*P, "cameras"), [], "problems[0].cameras"),
        (
            (*P, "cameras"),
            [{"eye": [1, 0, 1], "target": [0, 0, 0]}, {"eye": [1, 0, 1]}],
            "problems[0].cameras[1].target",
        ),
        ((*P, "family"), 3, "problems[0].family"),
        ((*P, "inside"), "yes", "problems[0].inside"),
        ((*P, "grasp"), 1, "problems[0].grasp"),
        ((*P, "target"), 0, "problems[0].target: only for a grasp"),
        ((*P, "approach_m"), 0.1, "problems[0].approach_m: only for a grasp"),
    ],
)
def test_bad_files_are_refused_naming_the_field(path, value, named, tmp_path):
    d = copy.deepcopy(_valid())
    _set(d, path, value)
    f = tmp_path / "bad.json"
    f.write_text(json.dumps(d))
    with pytest.raises(ScenarioError) as err:
        load_scenarios(f)
    assert f"bad.json: {named}" in str(err.value)


def test_unreadable_files_are_refused(tmp_path):
    f = tmp_path / "broken.json"
    f.write_text('{"name": "x", ')
    with pytest.raises(ScenarioError, match="broken.json: not valid JSON"):
        load_scenarios(f)
    with pytest.raises(ScenarioError, match="cannot read"):
        load_scenarios(tmp_path / "missing.json")


def test_generated_problems_are_sound(generated):
    panda = load_panda()
    checker = CollisionChecker()
    for p in generated.problems:
        labeler = CollisionLabeler(p.scene)
        both = np.stack([p.start, p.goal_q])
        assert not labeler.label(both).any(), "start or goal_q touches an obstacle"
        assert checker.feasible(both).all(), "start or goal_q in self or table collision"
        tf = panda.fk(p.goal_q)
        assert np.linalg.norm(tf.translation - p.goal_position) < 1e-5, "goal_q does not reach the goal"
        goal = Goal.from_pose(p.goal_position, p.goal_quaternion_xyzw)
        assert np.allclose(tf.rotation, goal.rotation, atol=1e-4)
        assert np.linalg.norm(panda.fk(p.start).translation - p.goal_position) >= 0.25
        assert direct_motion_collides(labeler, p.start, p.goal_q)


def test_judge_catches_a_clipping_path_and_passes_the_goal(generated):
    p = generated.problems[0]
    judge = PathJudge(p.scene)
    goal = Goal.from_pose(p.goal_position, p.goal_quaternion_xyzw)
    straight = judge.judge(np.stack([p.start, p.goal_q]), goal)  # the direct motion clips an obstacle
    assert straight.reached and straight.collision == "obstacle"
    assert judge.judge(p.goal_q[None], goal).collision == ""
    dense, ee = densify_by_ee(np.stack([p.start, p.goal_q]), judge.panda)
    assert np.linalg.norm(np.diff(ee, axis=0), axis=1).max() <= 0.01 + 1e-9
    assert np.abs(np.diff(dense, axis=0)).max() <= 0.02 + 1e-9


def test_shipped_default_set():
    assert DEFAULT_SET.stat().st_size < 1_000_000
    s = load_scenarios()
    assert len(s.problems) == 100 and s.table
    assert all(p.goal_q is not None and p.camera is not None and p.obstacles for p in s.problems)


def test_the_harness_cloud_reaches_as_high_as_the_arm():
    """A shelf board 1.05 m above the table (above the shipped collision network's box, 0.95 m) is in the
    planners' cloud: the harness crops like the sim camera, up to the arm's reach."""
    from latent_planner_ros.bench.table import problem_cloud
    from latent_planner_ros.data.camera import CameraConfig, planning_crop
    from latent_planner_ros.data.obstacles import Box

    board = Box((0.5, 0.0, 1.05), (0.0, 0.0, 0.0, 1.0), (0.15, 0.2, 0.01))
    problem = ScenarioProblem(
        start=np.zeros(7),
        goal_position=np.array([0.5, 0.0, 0.3]),
        goal_quaternion_xyzw=np.array([1.0, 0.0, 0.0, 0.0]),
        obstacles=(board,),
        cameras=(CameraSpec(eye=(1.5, 0.3, 1.6), target=(0.5, 0.0, 0.3), seed=0),),
    )
    cloud, origin = problem_cloud(problem, 0, table=True)
    on_board = np.abs(cloud[:, 2] - 1.06) < 0.01
    assert on_board.sum() > 50 and CameraConfig().crop_max[2] < 1.05 < planning_crop()[1][2]
    low, high = (np.asarray(c) for c in planning_crop())
    assert np.all(cloud >= low - 1e-6) and np.all(cloud <= high + 1e-6)


def test_several_cameras_round_trip_and_one_stays_camera(tmp_path):
    d = _valid()
    views = [
        {"eye": [1.5, 0.3, 1.6], "target": [0.5, 0.0, 0.3], "seed": 1},
        {"eye": [0.2, 1.2, 1.0], "target": [0.5, 0, 0]},
    ]
    d["problems"][0].update(cameras=views, family="bookshelf", inside=True)
    s = set_from_dict(d)
    p = s.problems[0]
    assert len(p.cameras) == 2 and p.camera == p.cameras[0] and p.family == "bookshelf" and p.inside
    back = save_scenarios(s, tmp_path / "s.json")
    again = load_scenarios(back).problems[0]
    assert again.cameras == p.cameras and again.family == "bookshelf" and again.inside
    out = again.to_dict()
    assert "camera" not in out and len(out["cameras"]) == 2
    one = set_from_dict(_valid() | {"problems": [_valid()["problems"][0] | {"cameras": views[:1]}]})
    assert "camera" in one.problems[0].to_dict() and "family" not in one.problems[0].to_dict()
    d["problems"][0]["camera"] = views[0]
    with pytest.raises(ScenarioError, match="either 'camera' or 'cameras'"):
        set_from_dict(d)


def test_the_harness_fuses_every_camera_with_one_origin_per_point():
    from latent_planner_ros.bench.table import problem_cloud
    from latent_planner_ros.data.obstacles import Box

    box = Box((0.5, 0.0, 0.2), (0.0, 0.0, 0.0, 1.0), (0.1, 0.1, 0.2))
    front, side = CameraSpec((1.6, 0.0, 0.6), (0.5, 0.0, 0.2), 3), CameraSpec((0.5, 1.4, 0.6), (0.5, 0.0, 0.2), 4)

    def make(cams):
        return ScenarioProblem(np.zeros(7), np.array([0.4, 0, 0.5]), np.array([1.0, 0, 0, 0]), (box,), None, cams)

    one, eye = problem_cloud(make((front,)), 0, table=False)
    both, origins = problem_cloud(make((front, side)), 0, table=False)
    assert eye.shape == (3,) and origins.shape == both.shape
    assert len(both) > len(one) and np.allclose(both[: len(one)], one)  # the first view is unchanged
    from_side = np.all(np.isclose(origins, side.eye), axis=1)
    assert from_side.sum() == len(both) - len(one) and np.all(np.isclose(origins[~from_side], front.eye))
    # every point lies on the box's surface within the depth noise, and each camera sees its own face
    local = np.abs(both - np.asarray(box.position)) - np.asarray(box.half_extents)
    assert np.all(np.abs(local.max(axis=1)) < 0.02)
    assert np.any(both[from_side, 1] > 0.095) and np.any(both[~from_side, 0] > 0.595)


def test_grasp_fields_round_trip_and_are_checked(tmp_path):
    d = _valid()
    d["problems"][0].update(grasp=True, target=1, approach_m=0.06)
    p = set_from_dict(d).problems[0]
    assert p.grasp and p.target == 1 and p.approach_m == 0.06
    again = load_scenarios(save_scenarios(set_from_dict(d), tmp_path / "g.json")).problems[0]
    assert (again.grasp, again.target, again.approach_m) == (True, 1, 0.06)
    plain = set_from_dict(_valid()).problems[0]
    assert not plain.grasp and plain.target is None and "grasp" not in plain.to_dict()
    n = len(d["problems"][0]["obstacles"])
    for key, value, named in (("target", n, "problems[0].target"), ("target", True, "problems[0].target"),
                              ("approach_m", -0.01, "problems[0].approach_m")):  # fmt: skip
        bad = copy.deepcopy(d)
        bad["problems"][0][key] = value
        with pytest.raises(ScenarioError, match=named.replace("[", r"\[").replace("]", r"\]")):
            set_from_dict(bad)

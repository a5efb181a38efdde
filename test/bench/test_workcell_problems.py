"""Workcell problems: one per family, valid on the true geometry (start and goal_q free with their clearances,
goal_q reaching the goal pose, inside goals in the clearance band with the TCP in their region), deterministic
in (seed, index), and written by the scenario generator's CLI."""

import numpy as np
import pytest

from latent_planner_ros.bench.scenario_generator import main
from latent_planner_ros.bench.scenarios import load_scenarios
from latent_planner_ros.bench.workcell_problems import (
    WorkcellConfig,
    default_workcell_cameras,
    generate_workcell_problem,
    workcell_problem_and_target,
)
from latent_planner_ros.data.workcell_clearance import ArmDistance
from latent_planner_ros.data.workcell_generator import WORKCELL_FAMILIES, generate_workcell_layout
from latent_planner_ros.data.workcell_regions import Region
from latent_planner_ros.robot.collision import CollisionChecker
from latent_planner_ros.robot.panda import load_panda
from latent_planner_ros.robot.rotations import quat_to_matrix

INSIDE = {"bookshelf", "bin", "undershelf"}
"""families tested with inside goals (the others with pregrasp goals)"""


@pytest.fixture(scope="module")
def problems():
    out = {}
    for family in WORKCELL_FAMILIES:
        config = WorkcellConfig(family=family, goal="inside" if family in INSIDE else "pregrasp", seed=321)
        out[family] = (config, *workcell_problem_and_target(0, config))
    return out


@pytest.mark.parametrize("family", WORKCELL_FAMILIES)
def test_problem_is_valid(problems, family):
    config, p, target = problems[family]
    assert p.family == family and p.inside == (family in INSIDE) and 2 <= len(p.cameras) <= 3
    checker, distance, panda = CollisionChecker(), ArmDistance(p.obstacles), load_panda()
    for q in (p.start, p.goal_q):
        assert not checker.in_collision(q)
    assert distance(p.start).distance >= config.clearance - 1e-3
    tcp = panda.fk(p.goal_q)
    np.testing.assert_allclose(tcp.translation, p.goal_position, atol=1e-5)
    np.testing.assert_allclose(tcp.rotation, quat_to_matrix(p.goal_quaternion_xyzw), atol=1e-5)
    assert np.linalg.norm(tcp.translation - panda.fk(p.start).translation) >= config.min_distance
    d = distance(p.goal_q).distance
    if p.inside:
        assert isinstance(target, Region) and target.contains(tcp.translation)
        assert config.inside_band[0] <= d <= config.inside_band[1]
    else:
        assert d >= config.goal_clearance
        off = float(np.dot(tcp.translation - np.asarray(target.centre), target.normal))
        lo, hi = config.pregrasp_offset
        assert lo - 2e-3 <= off <= hi + 2e-3  # IK converges to 1 mm


def test_deterministic_in_seed_and_index_and_split_matters(problems):
    config, p, _ = problems["cage"]
    again = generate_workcell_problem(0, config)
    assert again.to_dict(6) == p.to_dict(6)
    train = generate_workcell_problem(0, WorkcellConfig(family="cage", goal="pregrasp", seed=321, split="train"))
    assert train.to_dict(6)["obstacles"] != p.to_dict(6)["obstacles"]


def test_workcell_cycles_families_and_a_third_are_inside():
    config = WorkcellConfig(problems=120)
    kinds = [config.problem_kind(i) for i in range(120)]
    assert [f for f, _ in kinds[:6]] == list(WORKCELL_FAMILIES)
    assert sum(inside for _, inside in kinds) == 40
    for family in WORKCELL_FAMILIES:
        assert 6 <= sum(inside for f, inside in kinds if f == family) <= 7


def test_cameras_see_into_the_furniture():
    cell = generate_workcell_layout(np.random.default_rng(3), "bookshelf", split="train")
    cams = default_workcell_cameras(cell, np.random.default_rng(0))
    front = np.asarray(cell.furniture[0].front)
    eye = np.asarray(cams[0].eye) - np.asarray(cams[0].target)
    assert np.dot(eye[:2], front[:2]) > 0.5  # the first view looks in through the opening
    assert all(c.seed is not None for c in cams)
    assert len(default_workcell_cameras(cell.scene, np.random.default_rng(0))) == 2


def test_cli_writes_a_workcell_set(tmp_path):
    out = tmp_path / "wc.json"
    assert main(["--family", "wall", "--goal", "pregrasp", "--problems", "1", "--seed", "5", "--out", str(out)]) == 0
    s = load_scenarios(out)
    assert s.name == "wall_heldout" and s.problems[0].family == "wall" and len(s.problems[0].cameras) >= 2


def test_the_cameras_of_a_mixed_cell_also_see_the_clutter_beside_the_furniture():
    from scipy.spatial import cKDTree

    from latent_planner_ros.bench.scenarios import ScenarioProblem
    from latent_planner_ros.bench.table import problem_cloud
    from latent_planner_ros.data.obstacle_geometry import triangle_mesh

    cell = generate_workcell_layout(np.random.default_rng(5), "mixed", split="heldout")
    cams = default_workcell_cameras(cell, np.random.default_rng(0))
    assert len(cams) == 3
    problem = ScenarioProblem(np.zeros(7), np.zeros(3), np.array([0.0, 0, 0, 1]), cell.scene.obstacles, None, cams)
    tree = cKDTree(problem_cloud(problem, 0, table=True)[0])
    for obstacle, group in zip(cell.scene.obstacles, cell.scene.groups, strict=True):
        if group > 0:  # a tabletop object: some of its vertices have a cloud point within 2 cm
            assert (tree.query(triangle_mesh(obstacle)[0])[0] < 0.02).any()

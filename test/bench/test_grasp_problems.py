"""Grasp problems: the target is the last obstacle, the fingers surround it without touching, the arm keeps its
clearance from everything else, and the start and the approach are free on the true meshes."""

import numpy as np
import pytest

from latent_planner_ros.bench.grasp_problems import GraspSetConfig, generate_grasp_problem
from latent_planner_ros.bench.scenarios import problem_from_dict
from latent_planner_ros.data.labels import CollisionLabeler
from latent_planner_ros.data.scene import Scene
from latent_planner_ros.data.workcell_clearance import ArmDistance
from latent_planner_ros.robot.collision import CollisionChecker
from latent_planner_ros.robot.panda import load_panda

CONFIG = GraspSetConfig(seed=9400, split="train")


@pytest.fixture(scope="module")
def problems():
    return [generate_grasp_problem(i, CONFIG) for i in range(6)]


def test_grasp_problems_are_valid(problems):
    panda, checker = load_panda(), CollisionChecker()
    assert [p.family for p in problems] == ["bookshelf", "bin", "cage", "undershelf", "wall", "mixed"]
    for p in problems:
        assert p.grasp and p.target == len(p.obstacles) - 1 and p.approach_m == CONFIG.approach_m
        target, others = p.obstacles[p.target], p.obstacles[: p.target]
        tcp = panda.fk(p.goal_q)
        assert np.linalg.norm(tcp.translation - np.asarray(target.position)) < 1e-3  # the TCP at its centre
        assert ArmDistance(others)(p.goal_q).distance >= CONFIG.grasp_clearance - 1e-4
        assert ArmDistance([target])(p.goal_q).distance >= CONFIG.finger_gap - 1e-4
        assert not checker.in_collision(p.goal_q) and not checker.in_collision(p.start)
        assert not CollisionLabeler(Scene(p.obstacles)).label(np.stack([p.start, p.goal_q])).any()
        back = problem_from_dict(p.to_dict(6))
        assert back.grasp and back.target == p.target and back.approach_m == p.approach_m


def test_deterministic_in_seed_and_index(problems):
    again = generate_grasp_problem(2, CONFIG)
    assert again.to_dict(6) == problems[2].to_dict(6)

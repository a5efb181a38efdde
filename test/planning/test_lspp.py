"""LSPP with the shipped classifier: it avoids cylinders the planner without obstacle loss runs into."""

import numpy as np
import pytest
import torch

from latent_planner_ros.bench.lspp_scenarios import ScenarioGenerator, position_goal
from latent_planner_ros.data.cylinder_dataset import generate
from latent_planner_ros.data.cylinders import cylinder_scene
from latent_planner_ros.evaluation.path_check import PathJudge
from latent_planner_ros.models.collision_metrics import auroc
from latent_planner_ros.models.cylinder_classifier import load_classifier
from latent_planner_ros.planning.amp_ls import AmpLs, presets
from latent_planner_ros.planning.collision_backend import NoCollision
from latent_planner_ros.planning.lspp import make_variant


@pytest.fixture(scope="module")
def scenarios(shipped_vae):
    no_col = AmpLs(shipped_vae, NoCollision(), presets.lspp_seed(use_collision=False), seed=5)
    gen = ScenarioGenerator(no_col, seed=505)
    return [gen.draw(1) for _ in range(4)]


def test_the_shipped_classifier_separates_fresh_samples(shipped_vae):
    data = generate(2000, seed=99, pool=4000, progress=False)  # a seed the training never used
    model, meta = load_classifier()
    with torch.no_grad():
        z = shipped_vae.encode_q(torch.as_tensor(data.q, dtype=torch.float32))
        p = torch.sigmoid(model(z, torch.as_tensor(data.o, dtype=torch.float32))).numpy()
    assert auroc(p, data.c) > 0.95
    assert np.mean((p >= 0.5) == data.c) > 0.88
    assert meta["vae"]["name"] == "vae_kinematic"


@pytest.mark.slow
def test_lspp_reaches_around_the_cylinder_the_unguided_planner_hits(shipped_vae, scenarios):
    planner = make_variant("lspp", shipped_vae)
    solved = 0
    for i, sc in enumerate(scenarios):
        o = np.asarray(sc.cylinders)
        goal = position_goal(np.asarray(sc.target))
        planner.generator.manual_seed(i)
        result = planner.plan(np.asarray(sc.start), goal, o)
        verdict = PathJudge(cylinder_scene(o)).judge(result.q_path, goal)
        if result.success:
            assert verdict.reached and not verdict.collision  # a claimed success is a real one
            solved += 1
    assert solved >= 3


def test_the_seed_variant_runs_without_explicit_checks(shipped_vae, scenarios):
    planner = make_variant("lspp_seed", shipped_vae)
    assert planner.backend.check_mode == "none" and planner.config.search.n_seeds == 1
    sc = scenarios[0]
    result = planner.plan(np.asarray(sc.start), position_goal(np.asarray(sc.target)), np.asarray(sc.cylinders))
    assert result.iterations <= 300 and len(result.q_path) >= 1

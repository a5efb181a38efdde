"""A plan the network fails is planned again with the geometric backend, in the time left; the backend is
left as it was."""

import numpy as np

from latent_planner_ros.planning.amp_ls import AmpLs, AmpLsConfig
from latent_planner_ros.planning.amp_ls.config import with_overrides
from latent_planner_ros.planning.goal import Goal
from latent_planner_ros.planning.learned_backend import LearnedBackend
from latent_planner_ros.robot.limits import Q_READY
from latent_planner_ros.robot.panda import load_panda


def _goal() -> Goal:
    m = load_panda().fk(Q_READY + np.array([0.4, 0.2, 0.0, 0.3, 0.0, 0.0, 0.0]))
    return Goal(m.translation, m.rotation)


def test_a_plan_the_network_fails_is_planned_again_with_the_geometric_backend(shipped_vae):
    cloud = np.random.default_rng(0).uniform([0.6, -0.5, 0.0], [0.9, -0.3, 0.3], size=(300, 3))  # out of the way
    blind = LearnedBackend.load(threshold=0.0)  # p >= 0: the network calls every configuration colliding
    config = with_overrides(AmpLsConfig(collision_backend="learned", max_steps=40), {"escape": None})
    result = AmpLs(shipped_vae, blind, config).plan(Q_READY, _goal(), cloud)
    assert result.success, result.reason
    assert result.info["geometric_retry"].startswith("after the network's")
    assert result.info["collision_backend"] == "geometric"
    assert blind.mode == "learned" and not blind._forced  # as before the plan
    off = AmpLs(shipped_vae, blind, with_overrides(config, {"plan.geometric_retry": False}))
    failed = off.plan(Q_READY, _goal(), cloud)
    assert not failed.success and "geometric_retry" not in failed.info

"""With the shipped VAE and the default planner settings, open-loop reaching in free space succeeds >= 90 %."""

import numpy as np
import pytest

from latent_planner_ros.bench.planner import reached
from latent_planner_ros.planning.amp_ls import AmpLs, AmpLsConfig
from latent_planner_ros.planning.collision_backend import NoCollision
from latent_planner_ros.planning.problems import free_space_problems
from latent_planner_ros.robot.collision import CollisionChecker
from latent_planner_ros.robot.limits import Q_MAX, Q_MIN


@pytest.mark.slow
def test_fifty_random_free_space_targets(shipped_vae):
    planner = AmpLs(shipped_vae, NoCollision(), AmpLsConfig(collision_backend="none", use_collision=False))
    checker = CollisionChecker()
    successes = 0
    for problem in free_space_problems(50, seed=77):
        result = planner.plan(problem.start_q, problem.goal)
        ok, pos_err, ori_err = reached(result.q_path[-1], problem)  # pinocchio FK of the returned joints
        assert result.success == ok, (result.reason, pos_err, ori_err)
        q = result.q_path
        assert np.all(q >= Q_MIN - 1e-9) and np.all(q <= Q_MAX + 1e-9)
        assert checker.feasible(q).all(), "a path state is in self or table collision"
        successes += ok
    assert successes >= 45, f"{successes}/50 free-space targets reached"

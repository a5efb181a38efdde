"""The planner's GECO multipliers follow the seed's update (appendix 6.B.1) on a hand-computed case."""

import math

import numpy as np
import torch

from latent_planner_ros.planning.amp_ls import AmpLs, AmpLsConfig
from latent_planner_ros.planning.amp_ls.config import with_overrides
from latent_planner_ros.planning.collision_backend import NoCollision
from latent_planner_ros.planning.goal import Goal
from latent_planner_ros.robot.limits import Q_READY


class ConstantCollision(NoCollision):
    """p(collision) = 0.5 everywhere, and nothing ever fails the hard check."""

    def p_collision(self, q, z, frames=None):
        return torch.full((q.shape[0],), 0.5, dtype=q.dtype)


def test_multipliers_follow_the_moving_average_rule(shipped_vae):
    cfg = with_overrides(
        AmpLsConfig(collision_backend="none", lambda_col=2.0, geco_alpha_ma=0.9), {"search.n_seeds": 1}
    )
    planner = AmpLs(shipped_vae, ConstantCollision(), cfg)
    s = planner.new_search(Q_READY, n_seeds=1)
    goal = Goal(np.array([0.5, 0.0, 0.4]), np.eye(3))
    lam_t, lam_c, c_t_ma, c_c_ma = 1.0, 2.0, None, None
    for _ in range(3):
        z = s.z.detach().clone()
        l_prior = 0.5 * float(z.pow(2).mean())
        l_col = -math.log(1.0 - 0.5)
        planner.iterate(s, goal, accept=False)
        # C = constraint - target; C_ma = alpha * C_ma + (1 - alpha) * C (C_ma = C at first); lambda *= exp(step * C_ma)
        c_t = -l_prior + cfg.tau_prior  # lambda_target grows while the prior loss is below tau_prior
        c_c = l_col - cfg.tau_col  # lambda_col grows while the collision loss is above tau_col
        c_t_ma = c_t if c_t_ma is None else 0.9 * c_t_ma + 0.1 * c_t
        c_c_ma = c_c if c_c_ma is None else 0.9 * c_c_ma + 0.1 * c_c
        lam_t *= math.exp(cfg.geco_step_target * c_t_ma)
        lam_c *= math.exp(cfg.geco_step_col * c_c_ma)
        assert abs(s.target.value[0] - lam_t) < 1e-9 * lam_t
        assert abs(s.col.value[0] - lam_c) < 1e-9 * lam_c
    assert lam_c > 2.0  # a constant p = 0.5 is above the target: the collision weight keeps growing

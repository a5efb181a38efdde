"""The optimisation state of AMP-LS's latent seeds (`LatentSearch`) and the result of one closed-loop tick."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import torch

from latent_planner_ros.models.geco import Geco, GecoConfig
from latent_planner_ros.models.vae import RobotStateVAE
from latent_planner_ros.planning.amp_ls.config import AmpLsConfig


@dataclass
class StepResult:
    """One closed-loop tick.

    Attributes:
        command: (7,) next joint target [rad], within limits and reachable at the velocity limits in dt.
        accepted: a new collision-checked state was accepted this tick.
        reached: the last accepted state and the measured arm are both within tolerance of the goal.
        pos_err_m, ori_err_rad: error of the last accepted state to the goal.
        p_collision: collision probability of the current decoded state.
        reason: a short status ("tracking", "reached", "rejected: p_col", "backtraced", ...).
        losses: loss terms and multipliers of the last iteration.
        arm_pos_err_m: [m] error of the measured arm's TCP to the goal (None: not computed); the latent state can
            run ahead of an arm that does not follow, so progress is judged on this.
    """

    command: np.ndarray
    accepted: bool
    reached: bool
    pos_err_m: float
    ori_err_rad: float
    p_collision: float
    reason: str
    losses: dict = field(default_factory=dict)
    arm_pos_err_m: float | None = None


class LatentSearch:
    """Optimisation state of a batch of B latent seeds, started at the encoding of start_q (7,) [rad].

    Args:
        vae: the frozen robot-state VAE (encodes the start).
        config: the planner's configuration (seed count and noise, optimiser, GECO settings).
        generator: the planner's torch generator (the extra seeds' noise).
        start_q: (7,) [rad] the start state.
        n_seeds: B (default config.search.n_seeds).
        lr: the optimiser's step size (default config.lr).
    """

    def __init__(
        self,
        vae: RobotStateVAE,
        config: AmpLsConfig,
        generator: torch.Generator,
        start_q: np.ndarray,
        n_seeds: int | None = None,
        lr: float | None = None,
    ):
        cfg = config
        lr = cfg.lr if lr is None else lr
        b = cfg.search.n_seeds if n_seeds is None else n_seeds
        with torch.no_grad():
            z0 = vae.encode_q(torch.as_tensor(start_q, dtype=torch.float32)[None])
        z = z0.repeat(b, 1)
        if b > 1:
            z[1:] += cfg.search.seed_noise * torch.randn(b - 1, z.shape[1], generator=generator)
        self.z = torch.nn.Parameter(z)
        self.opt = torch.optim.Adam([self.z], lr=lr) if cfg.optimizer == "adam" else torch.optim.SGD([self.z], lr=lr)
        self.z_prev = self.z.detach().clone()
        self.q_prev = np.repeat(np.asarray(start_q, dtype=float)[None], b, axis=0)
        self.q_command = np.asarray(start_q, dtype=float).copy()
        self.paths: list[list[np.ndarray]] = [[np.asarray(start_q, dtype=float)[None]] for _ in range(b)]
        # lazy checking (open loop, checks.lazy): accepted states not yet hard-checked, as (q (7,), z (L,)),
        # after the last checked state q_ok / z_ok of each seed; q_prev / z_prev are then the last accepted one
        self.pending: list[list[tuple[np.ndarray, torch.Tensor]]] = [[] for _ in range(b)]
        self.q_ok = self.q_prev.copy()
        self.z_ok = self.z_prev.clone()
        geco = dict(alpha_ma=cfg.geco_alpha_ma, lambda_min=cfg.lambda_min, lambda_max=cfg.lambda_max)
        # lambda_target scales lambda_pos and lambda_ori together
        self.target = Geco(GecoConfig(tau=-cfg.tau_prior, step=cfg.geco_step_target, lambda_init=1.0, **geco), (b,))
        self.col = Geco(GecoConfig(tau=cfg.tau_col, step=cfg.geco_step_col, lambda_init=cfg.lambda_col, **geco), (b,))
        self.best_err = np.full(b, np.inf)
        self.guide_q = np.full((b, 7), np.nan)  # goal guidance: each seed's joint-space target (NaN: the pose)
        self.best_guide_err = np.full(b, np.inf)  # [rad] smallest max-joint distance to guide_q so far
        self.goal_qs: list[np.ndarray] | None = None  # goal configurations, once searched
        self.finish_tried = np.full(b, -(10**9))  # iteration of each seed's last exact-finish attempt
        self.direct_refused: list[np.ndarray] = []  # ends (7,) whose straight segment from the start collided
        self.last_improved = np.zeros(b, dtype=int)
        self.iteration = 0
        self.backtraces = 0
        self.restarts = 0
        self.last_losses: dict = {}

    @property
    def start(self) -> np.ndarray:
        """(7,) [rad] the start state (the first state of every seed's path)."""
        return self.paths[0][0][0]

    def best(self) -> int:
        """The seed whose TCP came nearest the goal so far."""
        return int(np.argmin(self.best_err))

    def restart(self, b: int, t: int, noise: float, generator: torch.Generator, guide_q: np.ndarray | None) -> None:
        """Move stalled seed b to the best seed's last accepted state at iteration t, with a latent kick of std
        `noise` [latent units]; guide_q (7,) [rad]: its goal configuration from now on (None: unchanged)."""
        best = self.best()
        if guide_q is not None:
            self.guide_q[b] = guide_q
            self.best_guide_err[b] = np.inf
        with torch.no_grad():
            self.z_prev[b] = self.z_prev[best]
            self.z[b] = self.z_prev[best] + noise * torch.randn(self.z.shape[1], generator=generator)
        for state in self.opt.state.values():  # forget this seed's optimiser moments
            for v in state.values():
                if torch.is_tensor(v) and v.dim() > 0:
                    v[b] = 0.0
        self.q_prev[b] = self.q_prev[best]
        self.paths[b] = list(self.paths[best])
        self.pending[b] = list(self.pending[best])
        self.q_ok[b] = self.q_ok[best]
        with torch.no_grad():
            self.z_ok[b] = self.z_ok[best]
        for geco in (self.target, self.col):  # the best seed's multipliers
            geco.log_lambda[b] = geco.log_lambda[best]
            if geco.c_ma is not None:
                geco.c_ma[b] = geco.c_ma[best]
        self.best_err[b], self.last_improved[b] = self.best_err[best], t
        self.restarts += 1

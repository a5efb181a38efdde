"""GECO: a Lagrange multiplier on a moving average of a constraint (Rezende & Viola, 2018).

One rule serves training (the VAE's reconstruction constraint) and planning (the seed's appendix 6.B.1,
where the planning loss weights are adapted online):

    C_t    = l_t - tau
    C_ma_t = C_0                                   if t == 0
           = alpha_ma * C_ma_{t-1} + (1 - alpha_ma) * C_t   otherwise
    lambda_{t+1} = lambda_t * exp(step * C_ma_t)

The update is carried out on log(lambda) and clamped to [lambda_min, lambda_max], so a loss spike can
neither overflow exp nor leave lambda stuck at a bound for long. Losses may be scalars or arrays (one
multiplier per element, e.g. per latent seed of a batched planner).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


@dataclass
class GecoConfig:
    """Parameters of one GECO multiplier."""

    tau: float = 1e-3
    """constraint target: lambda grows while the moving average of the loss is above it"""
    alpha_ma: float = 0.95
    """moving-average factor of the constraint"""
    step: float = 0.1
    """GECO learning rate (per unit of constraint violation)"""
    lambda_init: float = 1.0
    lambda_min: float = 1e-10
    lambda_max: float = 1e6

    def __post_init__(self) -> None:
        if not 0.0 <= self.alpha_ma < 1.0:
            raise ValueError(f"alpha_ma must be in [0, 1), got {self.alpha_ma}")
        if not 0.0 < self.lambda_min <= self.lambda_init <= self.lambda_max:
            raise ValueError("need 0 < lambda_min <= lambda_init <= lambda_max")


class Geco:
    """State of one multiplier (or an array of them, with `shape`).

    Call :meth:`update` with the current loss value(s); read :attr:`value`.
    """

    def __init__(self, config: GecoConfig, shape: tuple[int, ...] = ()):
        self.config = config
        self.log_lambda = np.full(shape, math.log(config.lambda_init))
        self.c_ma: np.ndarray | None = None

    @property
    def value(self):
        """The current multiplier(s) lambda: a float for a scalar multiplier, else an array."""
        v = np.exp(self.log_lambda)
        return float(v) if v.ndim == 0 else v

    def update(self, loss, tau: float | None = None):
        """Feed the loss value(s) (optionally with a scheduled target); returns the new lambda(s)."""
        cfg = self.config
        c = np.asarray(loss, dtype=float) - (cfg.tau if tau is None else tau)
        self.c_ma = c if self.c_ma is None else cfg.alpha_ma * self.c_ma + (1.0 - cfg.alpha_ma) * c
        lo, hi = math.log(cfg.lambda_min), math.log(cfg.lambda_max)
        self.log_lambda = np.clip(self.log_lambda + cfg.step * self.c_ma, lo, hi)
        return self.value

    def scale(self, factor) -> None:
        """Multiply lambda by `factor` (scalar or per element), within the bounds."""
        cfg = self.config
        f = np.maximum(np.asarray(factor, dtype=float), 1e-12)
        self.log_lambda = np.clip(self.log_lambda + np.log(f), math.log(cfg.lambda_min), math.log(cfg.lambda_max))

    def state_dict(self) -> dict:
        c_ma = None if self.c_ma is None else np.asarray(self.c_ma).tolist()
        return {"log_lambda": np.asarray(self.log_lambda).tolist(), "c_ma": c_ma}

    def load_state_dict(self, state: dict) -> None:
        self.log_lambda = np.asarray(state["log_lambda"], dtype=float)
        self.c_ma = None if state["c_ma"] is None else np.asarray(state["c_ma"], dtype=float)

"""GECO: a Lagrange multiplier on a moving average of a constraint (Rezende & Viola, 2018).

One rule serves training (the VAE's reconstruction constraint) and planning (the seed's appendix 6.B.1,
where lambda_prior and lambda_col are adapted against the target loss):

    C_t    = l_t - tau
    C_ma_t = C_0                                   if t == 0
           = alpha_ma * C_ma_{t-1} + (1 - alpha_ma) * C_t   otherwise
    lambda_{t+1} = lambda_t * exp(step * C_ma_t)

The update is carried out on log(lambda) and clamped to [lambda_min, lambda_max], so a loss spike can
neither overflow exp nor leave lambda stuck at a bound for long.
"""

from __future__ import annotations

import math
from dataclasses import dataclass


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
    """State of one multiplier. Call :meth:`update` with the current loss value; read :attr:`value`."""

    def __init__(self, config: GecoConfig):
        self.config = config
        self.log_lambda = math.log(config.lambda_init)
        self.c_ma: float | None = None

    @property
    def value(self) -> float:
        """The current multiplier lambda."""
        return math.exp(self.log_lambda)

    def update(self, loss: float, tau: float | None = None) -> float:
        """Feed one loss value (optionally with a scheduled target); returns the new lambda."""
        cfg = self.config
        c = float(loss) - (cfg.tau if tau is None else tau)
        self.c_ma = c if self.c_ma is None else cfg.alpha_ma * self.c_ma + (1.0 - cfg.alpha_ma) * c
        self.log_lambda = min(
            max(self.log_lambda + cfg.step * self.c_ma, math.log(cfg.lambda_min)), math.log(cfg.lambda_max)
        )
        return self.value

    def state_dict(self) -> dict:
        return {"log_lambda": self.log_lambda, "c_ma": self.c_ma}

    def load_state_dict(self, state: dict) -> None:
        self.log_lambda = float(state["log_lambda"])
        self.c_ma = None if state["c_ma"] is None else float(state["c_ma"])

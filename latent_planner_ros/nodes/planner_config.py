"""Parameters of the planner node: one dataclass, mapped 1:1 onto ROS parameters (config/planner.yaml)."""

from __future__ import annotations

from dataclasses import dataclass, field

from latent_planner_ros.planning.amp_ls_config import AmpLsConfig
from latent_planner_ros.planning.closed_loop import ClosedLoopConfig


@dataclass
class PlannerNodeConfig:
    enabled: bool = True
    """track the goal in closed loop from the start (the enable service switches it)"""
    vae_checkpoint: str = ""
    """VAE checkpoint stem; empty = the shipped default"""
    collision_checkpoint: str = ""
    """collision-predictor checkpoint stem (learned backend); empty = the shipped default"""
    status_rate_hz: float = 2.0
    """status publishing rate [Hz]"""
    closed_loop: ClosedLoopConfig = field(default_factory=ClosedLoopConfig)
    amp_ls: AmpLsConfig = field(default_factory=AmpLsConfig)

    def __post_init__(self) -> None:
        if not (isinstance(self.status_rate_hz, int | float) and 0 < self.status_rate_hz <= 100):
            raise ValueError(f"status_rate_hz must be in (0, 100], got {self.status_rate_hz!r}")

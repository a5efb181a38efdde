"""AMP-LS (seed chapter 7) as composed parts; see planner.py for the algorithm and config.py for its settings.

    from latent_planner_ros.planning.amp_ls import AmpLs, AmpLsConfig, presets
    planner = AmpLs(vae, backend, presets.get("default"))
    result = planner.plan(start_q, goal, cloud)

Modules: config (AmpLsConfig and one sub-configuration per part), presets (default, seed, lspp, lspp_seed),
planner (Algorithm 1: iterate, accept, back-trace, GECO; plan and step), search (the latent seeds),
checker (the hard check of segments, the start's escape, lazy verification), finish (straight first, exact
finish, goal guidance), escape_part (the RRT escape). Parts import config, search and checker only, never the
planner.
"""

from latent_planner_ros.planning.amp_ls import presets
from latent_planner_ros.planning.amp_ls.config import (
    BACKENDS,
    AmpLsConfig,
    CheckConfig,
    EscapeConfig,
    FinishConfig,
    GuidanceConfig,
    PlanConfig,
    SearchConfig,
)
from latent_planner_ros.planning.amp_ls.planner import AmpLs
from latent_planner_ros.planning.amp_ls.search import LatentSearch, StepResult

__all__ = [
    "BACKENDS",
    "AmpLs",
    "AmpLsConfig",
    "CheckConfig",
    "EscapeConfig",
    "FinishConfig",
    "GuidanceConfig",
    "LatentSearch",
    "PlanConfig",
    "SearchConfig",
    "StepResult",
    "presets",
]

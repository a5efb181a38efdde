"""LSPP (seed chapter 6): the AMP-LS core planner configured for state-based cylinder obstacles.

Chapter 6, Algorithm 1 is AMP-LS without orientation, with the obstacle loss sum_i -log(1 - p(z, o_i)) from the
cylinder classifier and the GECO multipliers of appendix 6.B.1. Its two configurations are the presets
`lspp_seed` (the seed's planner) and `lspp` (the default, with this project's search; amp_ls/presets.py).
"""

from __future__ import annotations

from latent_planner_ros.models.vae import RobotStateVAE
from latent_planner_ros.planning.amp_ls import AmpLs, AmpLsConfig, presets
from latent_planner_ros.planning.amp_ls.config import with_overrides
from latent_planner_ros.planning.cylinder_backend import CylinderBackend

VARIANTS = {"lspp": (presets.lspp, "exact"), "lspp_seed": (presets.lspp_seed, "none")}
"""Named LSPP variants: (configuration preset, hard check of the cylinder backend)."""


def make_lspp(
    vae: RobotStateVAE,
    config: AmpLsConfig | None = None,
    classifier_stem: str | None = None,
    check: str = "exact",
    seed: int = 0,
) -> AmpLs:
    """An LSPP planner; `plan(start_q, goal, cylinders (K, 4))` plans around the cylinders (x, y, h, r) [m].

    check: the backend's hard check, "exact" or "none" (the seed's variant). Raises CheckpointError when the
    classifier checkpoint is missing or bad.
    """
    backend = CylinderBackend.load(classifier_stem, check=check)
    planner = AmpLs(vae, backend, config or presets.lspp(), seed=seed)
    planner.name = "lspp"
    return planner


def make_variant(
    name: str, vae: RobotStateVAE, classifier_stem: str | None = None, seed: int = 0, **overrides
) -> AmpLs:
    """A planner of VARIANTS[name] with config overrides ({"lr": 0.03, "search.n_seeds": 16}, as
    amp_ls.config.with_overrides takes them); ValueError for an unknown name or override."""
    if name not in VARIANTS:
        raise ValueError(f"unknown LSPP variant {name!r}; choose one of {sorted(VARIANTS)}")
    preset, check = VARIANTS[name]
    planner = make_lspp(vae, with_overrides(preset(), overrides), classifier_stem, check, seed)
    planner.name = name
    return planner

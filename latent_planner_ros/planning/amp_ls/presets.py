"""Named configurations of AMP-LS: this project's default, the seed's planner, and LSPP (chapter 6) on the same core.

    presets.get("lspp", max_steps=300)     # top-level overrides; dataclasses.replace for a part's fields

- `default`: AmpLsConfig() (every part on; bench table measures each part against it, docs/benchmark.md).
- `seed`: the seed's AMP-LS (chapter 7, Algorithm 1): one latent trajectory, every accepted step checked as it is
  accepted at a fixed m = interp_steps, the seed's single step size, no part beyond the seed.
- `lspp_seed`: the seed's LSPP (chapter 6, Algorithm 1 and Table 6.2): position-only goals around cylinder
  obstacles, one latent trajectory, Adam with alpha_AM = 0.03, T = 300 steps, GECO obstacle target tau_obs = 0.7
  (p = 0.5), no explicit collision check beyond the classifier's (the planner node: lspp_check none), no early stop.
- `lspp`: LSPP with this project's search and finishing: 32 latent seeds with 192 restarts of stalled seeds, half
  of the free part of a colliding step kept when back-tracing, exact checks of every interpolated state against
  the cylinders, the table and the arm, checked lazily, and AMP-LS's exact finish, straight first and shortcuts
  (chosen on validation scenarios, `bench lspp --seed 8`; docs/benchmark.md).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace

from latent_planner_ros.planning.amp_ls.config import AmpLsConfig, CheckConfig, FinishConfig, PlanConfig, SearchConfig


def default(**overrides) -> AmpLsConfig:
    """This project's AMP-LS: every part on."""
    return AmpLsConfig(**overrides)


def seed(**overrides) -> AmpLsConfig:
    """The seed's AMP-LS (chapter 7, Algorithm 1) on the point-cloud backends."""
    base = AmpLsConfig(
        search=SearchConfig(n_seeds=1, restarts=0, plan_lr=0.06, target_on_fk=True),
        checks=CheckConfig(check_step_rad=0.0, lazy=False, self_check=False, escape_rad=0.0),
        plan=PlanConfig(timeout_s=0.0, geometric_retry=False, shortcut=False),
        finish=None,
        guidance=None,
        escape=None,
    )
    return replace(base, **overrides)


def lspp_seed(**overrides) -> AmpLsConfig:
    """The seed's LSPP (chapter 6, Algorithm 1 and Table 6.2) on the core planner."""
    base = AmpLsConfig(
        collision_backend="cylinders",
        use_orientation=False,
        max_steps=300,
        lr=0.03,
        tau_col=0.7,
        search=SearchConfig(n_seeds=1, restarts=0, plan_lr=0.03, patience=300),
        checks=CheckConfig(lazy=False, self_check=False),
        plan=PlanConfig(timeout_s=0.0, shortcut=False),
        finish=None,
        guidance=None,
        escape=None,
    )
    return replace(base, **overrides)


def lspp(**overrides) -> AmpLsConfig:
    """LSPP with multi-seed search and restarts, lazy exact checks of the interpolated states, the exact finish,
    straight first and shortcuts (the default LSPP)."""
    base = AmpLsConfig(
        collision_backend="cylinders",
        use_orientation=False,
        search=SearchConfig(n_seeds=32, restarts=192, plan_lr=0.06),
        checks=CheckConfig(backtrace_keep=0.5, lazy=True, self_check=True),
        plan=PlanConfig(timeout_s=0.0, shortcut=True),
        finish=FinishConfig(),
        guidance=None,
        escape=None,
    )
    return replace(base, **overrides)


PRESETS: dict[str, Callable[..., AmpLsConfig]] = {
    "default": default,
    "seed": seed,
    "lspp": lspp,
    "lspp_seed": lspp_seed,
}
"""The presets by name (the planner nodes' `amp_ls.preset` / `lspp.preset`)."""


def get(name: str, **overrides) -> AmpLsConfig:
    """The preset `name` with top-level field overrides; ValueError naming the presets for an unknown one."""
    if name not in PRESETS:
        raise ValueError(f"unknown AMP-LS preset {name!r}; choose one of {', '.join(PRESETS)}")
    return PRESETS[name](**overrides)

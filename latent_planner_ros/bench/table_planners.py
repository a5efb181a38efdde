"""The planners of `bench table`: AMP-LS, its ablations and beyond-the-seed variants, and the OMPL planners.

Every entry is built from its default configuration plus the overrides below, so the table measures exactly
one switch per row against `amp_ls` (the default configuration). Budgets (the seed's, chapter 7 V-B):
AMP-LS at most `max_steps` optimisation steps (stopping earlier on "no progress"); RRTConnect and LBKPIECE1
until their first solution or 5 s (MoveIt's default timeout); RRTstar, PRMstar and BITstar for a fixed 1 s;
OMPL solutions are simplified for at most 0.5 s. All planning times are wall clock and include each planner's
scene processing (AMP-LS: encoding the cloud; OMPL: building the octree and the IK goal states).
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field

from latent_planner_ros.planning.amp_ls import AmpLsConfig
from latent_planner_ros.planning.amp_ls.config import with_overrides
from latent_planner_ros.planning.ompl_baseline_config import PLANNERS, OmplConfig


@dataclass(frozen=True)
class AmpLsVariant:
    """An AMP-LS row: config overrides over AmpLsConfig() (as amp_ls.config.with_overrides takes them: "lr",
    "search.n_seeds", "finish": None), the VAE checkpoint, and what it measures."""

    what: str
    overrides: dict = field(default_factory=dict)
    vae: str = ""
    """checkpoint stem in the shipped checkpoints ("" = the default VAE)"""
    backend: str = ""
    """collision backend ("" = the run's default backend)"""


AMP_LS_VARIANTS: dict[str, AmpLsVariant] = {
    "amp_ls": AmpLsVariant("default configuration"),
    "amp_ls_no_col": AmpLsVariant("seed ablation: no collision loss and no explicit check", {"use_collision": False}),
    "amp_ls_no_prior": AmpLsVariant("seed ablation: no prior loss", {"use_prior": False}),
    "amp_ls_single_seed": AmpLsVariant(
        "beyond the seed (b) off: one latent trajectory, no restarts", {"search.n_seeds": 1, "search.restarts": 0}
    ),
    "amp_ls_plain_vae": AmpLsVariant(
        "beyond the seed (a) off: the seed's plain VAE, target losses on the decoded pose (the learned "
        "predictor reads the latent of its own VAE, re-encoded from the decoded q)",
        {"search.target_on_fk": False},
        vae="vae_plain",
    ),
    "amp_ls_geometric": AmpLsVariant(
        "beyond the seed (c): geometric backend (arm spheres vs cloud) instead of the learned predictor",
        backend="geometric",
    ),
    "amp_ls_local": AmpLsVariant(
        "the local collision predictor (the cloud points next to each link) instead of the grid network",
        backend="local",
    ),
    "amp_ls_no_self_check": AmpLsVariant(
        "beyond the seed off: no exact self/table check of interpolated steps", {"checks.self_check": False}
    ),
    "amp_ls_eager_check": AmpLsVariant(
        "beyond the seed off: every accepted step checked as it is accepted (the seed), not lazily",
        {"checks.lazy": False},
    ),
    "amp_ls_no_finish": AmpLsVariant(
        "beyond the seed off: no exact IK finish, the latent optimisation reaches alone", {"finish": None}
    ),
    "amp_ls_no_direct_first": AmpLsVariant(
        "beyond the seed off: no straight segment to an IK solution from the start before optimising",
        {"finish.direct_first": False},
    ),
    "amp_ls_no_shortcut": AmpLsVariant("beyond the seed off: no shortcutting of the path", {"plan.shortcut": False}),
    "amp_ls_no_escape": AmpLsVariant(
        "beyond the seed off: a start refused by the hard check is not left (escape_rad 0)", {"checks.escape_rad": 0.0}
    ),
    "amp_ls_no_guidance": AmpLsVariant(
        "beyond the seed off: restarts keep the pose target (no IK goal configurations)", {"guidance": None}
    ),
    "amp_ls_seed_lr": AmpLsVariant("the closed loop's step size (lr 0.06) for plans too", {"search.plan_lr": 0.06}),
    "amp_ls_no_rrt_escape": AmpLsVariant(
        "beyond the seed off: no RRT escape when the latent search stalls (escape None)",
        {"escape": None},
    ),
}
"""AMP-LS rows of the table, in order."""

OMPL_NAMES = tuple(PLANNERS)
"""OMPL rows: rrtconnect, rrtstar, prmstar, lbkpiece, bitstar."""

ALL_PLANNERS = (*AMP_LS_VARIANTS, *OMPL_NAMES)

SEED_TABLE_I = {
    "amp_ls": (0.75, 0.26, 5.25),
    "amp_ls_no_col": (0.46, 0.12, 3.68),
    "amp_ls_no_prior": (0.35, 0.24, 3.23),
    "rrtconnect": (0.86, 1.60, 2.17),
    "rrtstar": (0.36, None, 2.25),
    "prmstar": (0.82, None, 2.26),
    "lbkpiece": (0.23, 2.54, 2.34),
    "bitstar": (0.63, None, 2.42),
}
"""The seed's Table I (success, planning time [s], normalised path length); prmstar row = the seed's Lazy PRM*."""


def amp_ls_config(name: str, backend: str, overrides: dict | None = None) -> AmpLsConfig:
    """The AmpLsConfig of row `name` with the run's default collision backend `backend`, and the run's
    `overrides` over the row's own (ValueError for an unknown field or a refused value)."""
    v = AMP_LS_VARIANTS[name]
    return with_overrides(AmpLsConfig(collision_backend=v.backend or backend), {**v.overrides, **(overrides or {})})


def parse_overrides(items: list[str]) -> dict:
    """{"escape.after_s": 0.25, "finish": None} from ["escape.after_s=0.25", "finish=null"] (values as JSON, else
    strings), checked against AmpLsConfig; ValueError names the bad item."""
    out: dict = {}
    for item in items:
        key, eq, text = item.partition("=")
        if not eq or not key.strip():
            raise ValueError(f"expected KEY=VALUE, got {item!r}")
        try:
            out[key.strip()] = json.loads(text)
        except json.JSONDecodeError:
            out[key.strip()] = text
    with_overrides(AmpLsConfig(), out)
    return out


def ompl_config(name: str, table: bool) -> OmplConfig:
    """The OmplConfig of row `name` (the defaults: the seed's budgets)."""
    return OmplConfig(planner=name, table=table)


def parse_planners(text: str | None, default_backend: str) -> list[str]:
    """Row names from "a,b,c" (None: every row); raises ValueError naming an unknown one."""
    names = list(ALL_PLANNERS) if not text else [n.strip() for n in text.split(",") if n.strip()]
    unknown = [n for n in names if n not in ALL_PLANNERS]
    if unknown:
        raise ValueError(f"unknown planner(s) {unknown}; choose from {', '.join(ALL_PLANNERS)}")
    if not text and default_backend == "geometric":
        names.remove("amp_ls_geometric")  # identical to amp_ls when the default backend is already geometric
    return names


def budgets(overrides: dict | None = None) -> dict:
    """The budgets of every row (AMP-LS's with the run's `overrides`), for the report."""
    a, o = with_overrides(AmpLsConfig(), overrides or {}), OmplConfig()
    return {
        "amp_ls": {
            "max_steps": a.max_steps,
            "patience_steps": a.search.patience,
            "n_seeds": a.search.n_seeds,
            "rrt_escape_after_s": a.escape.after_s if a.escape else None,
            "rrt_escape_budget_s": a.escape.budget_s if a.escape else 0.0,
        },
        "rrtconnect": {"timeout_s": o.timeout_s},
        "lbkpiece": {"timeout_s": o.timeout_s},
        "rrtstar": {"fixed_budget_s": o.anytime_budget_s},
        "prmstar": {"fixed_budget_s": o.anytime_budget_s},
        "bitstar": {"fixed_budget_s": o.anytime_budget_s},
        "ompl_simplify_s": o.simplify_time_s if o.simplify else 0.0,
        "ompl_octree_resolution_m": o.octree_resolution,
        "ompl_ik": {"n_seeds": o.ik.n_seeds, "max_solutions": o.ik.max_solutions},
    }

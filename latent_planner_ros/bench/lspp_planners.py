"""The planners of `bench lspp`: LSPP (ours and the seed's configuration) and the classical baselines.

LSPP rows see the cylinders through the obstacle classifier (and, in `lspp`, the exact hard check of
interpolated states); the baselines see the exact cylinder geometry: the OMPL planners check the arm's meshes
against the cylinders (coal), the potential field pushes the arm's control points away from the cylinders.
Budgets: LSPP at most `max_steps` optimisation steps; RRTConnect and LBKPIECE1 until their first solution or 5 s;
RRTstar, PRMstar and BITstar a fixed 1 s (OmplConfig defaults); the potential field its step budget.
"""

from __future__ import annotations

from latent_planner_ros.planning.lspp import VARIANTS
from latent_planner_ros.planning.ompl_baseline_config import PLANNERS

OMPL_NAMES = tuple(PLANNERS)
ALL_PLANNERS = (*VARIANTS, *OMPL_NAMES, "potential_field")
DEFAULT_PLANNERS = ("lspp", "lspp_seed", "rrtconnect", "potential_field")

SEED_TABLE_II = {
    "lspp": ([85.8, 59.4, 38.2, 25.0, 15.7], [179.8, 185.5, 189.8, 191.9, 201.0], [1.52, 1.51, 1.47, 1.50, 1.48]),
    "potential_field": (
        [34.2, 20.5, 15.7, 11.4, 5.3],
        [1973.5, 2048.2, 2104.1, 2125.8, 2148.4],
        [1.54, 1.57, 1.54, 1.53, 1.53],
    ),
    "rrtconnect": ([84.9, 58.8, 47.7, 34.5, 26.8], [128.3, 150.5, 180.9, 195.9, 231.9], [2.33, 2.25, 2.24, 2.12, 2.15]),
    "lbkpiece": ([82.9, 57.8, 49.1, 32.5, 25.3], [401.7, 437.0, 526.8, 539.1, 561.6], [2.27, 2.26, 2.16, 2.07, 1.94]),
    "rrtstar": ([85.0, 58.1, 47.7, 33.2, 25.9], None, [1.53, 1.50, 1.48, 1.50, 1.47]),
    "bitstar": ([85.7, 58.0, 48.3, 34.8, 26.9], None, [2.13, 1.94, 1.87, 2.06, 1.98]),
}
"""The seed's Table II for 1-5 obstacles: success [%], planning time [ms], normalised path length."""


def build_planners(names: list[str], classifier: str | None = None, lspp_overrides: dict | None = None) -> dict:
    """name -> planner, each built once (the VAE is shared by the LSPP rows); lspp_overrides change the `lspp`
    row's configuration."""
    from latent_planner_ros.models.vae_io import load_vae
    from latent_planner_ros.planning.lspp import make_variant
    from latent_planner_ros.planning.ompl_baseline import seed_ompl

    seed_ompl(1)
    vae = load_vae()[0] if any(n in VARIANTS for n in names) else None
    planners: dict = {}
    for name in names:
        if name in VARIANTS:
            overrides = (lspp_overrides or {}) if name == "lspp" else {}
            planner = make_variant(name, vae, classifier, **overrides)
            planner.warm_up()
        elif name == "potential_field":
            from latent_planner_ros.planning.potential_field import PotentialFieldPlanner

            planner = PotentialFieldPlanner()
        else:
            from latent_planner_ros.planning.ompl_baseline_config import OmplConfig
            from latent_planner_ros.planning.ompl_exact import ExactOmplPlanner

            planner = ExactOmplPlanner(OmplConfig(planner=name, table=True))
        planners[name] = planner
    return planners

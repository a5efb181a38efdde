"""AmpLsConfig: the seed's fields at the top, one sub-configuration per part (None = off), presets, overrides."""

import math

import pytest

from latent_planner_ros.planning.amp_ls import AmpLsConfig, FinishConfig, presets
from latent_planner_ros.planning.amp_ls.config import with_overrides


def test_overrides_set_top_level_and_part_fields_and_switch_parts_off():
    cfg = with_overrides(AmpLsConfig(), {"lr": 0.03, "search.n_seeds": 3, "guidance": None, "escape.budget_s": 2.0})
    assert cfg.lr == 0.03 and cfg.search.n_seeds == 3 and cfg.guidance is None and cfg.escape.budget_s == 2.0
    assert cfg.search.restarts == AmpLsConfig().search.restarts  # the rest of the part is kept
    assert AmpLsConfig().search.n_seeds == 8  # the default is untouched
    on = with_overrides(presets.seed(), {"finish.max_rad": 1.0})  # a field of a part that is off switches it on
    assert on.finish == FinishConfig(max_rad=1.0)


@pytest.mark.parametrize(
    ("overrides", "message"),
    [
        ({"teleport": 1}, "unknown AMP-LS field 'teleport'"),
        ({"search.teleport": 1}, "unknown AMP-LS field 'search.teleport'"),
        ({"magic.n_seeds": 1}, "unknown AMP-LS field 'magic.n_seeds'"),
        ({"search.n_seeds": 0}, "search.n_seeds must be an integer >= 1"),
        ({"finish.radius_m": 0.0}, "finish.radius_m must be a number > 0"),
        ({"escape": None, "escape.budget_s": 1.0}, "switch escape off and set escape.budget_s"),
        ({"checks.check_step_rad": 0.6}, r"checks.check_step_rad must be 0 or in \[0.001, 0.5\]"),
    ],
)
def test_bad_overrides_are_refused_by_name(overrides, message):
    with pytest.raises(ValueError, match=message):
        with_overrides(AmpLsConfig(), overrides)


def test_a_part_must_be_its_config_or_none():
    with pytest.raises(ValueError, match="finish must be a FinishConfig or None"):
        AmpLsConfig(finish=True)
    with pytest.raises(ValueError, match="search must be a SearchConfig, got None"):
        AmpLsConfig(search=None)


def test_presets_select_the_parts():
    d = presets.get("default")
    assert d == AmpLsConfig() and d.finish.radius_m == math.inf and d.escape is not None
    seed = presets.get("seed")
    assert seed.finish is None and seed.guidance is None and seed.escape is None
    assert (seed.search.n_seeds, seed.search.restarts, seed.checks.lazy, seed.plan.shortcut) == (1, 0, False, False)
    assert seed.checks.check_step_rad == 0.0  # the seed's fixed m = interp_steps
    lspp = presets.get("lspp")
    assert (lspp.collision_backend, lspp.use_orientation, lspp.search.n_seeds, lspp.search.restarts) == (
        "cylinders",
        False,
        32,
        192,
    )
    assert lspp.checks.backtrace_keep == 0.5 and lspp.plan.timeout_s == 0.0
    assert lspp.finish is not None and lspp.plan.shortcut and lspp.checks.lazy  # AMP-LS's finishing parts
    lspp_seed = presets.get("lspp_seed", max_steps=100)
    assert (lspp_seed.max_steps, lspp_seed.lr, lspp_seed.tau_col, lspp_seed.search.patience) == (100, 0.03, 0.7, 300)
    with pytest.raises(ValueError, match="unknown AMP-LS preset 'fast'; choose one of default, seed, lspp, lspp_seed"):
        presets.get("fast")


def test_to_dict_is_nested_with_none_for_parts_that_are_off():
    d = presets.seed().to_dict()
    assert d["finish"] is None and d["search"]["n_seeds"] == 1 and d["lr"] == 0.06

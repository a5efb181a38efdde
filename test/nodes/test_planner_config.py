"""PlannerNodeConfig: config/planner.yaml gives the defaults; the obstacle and LSPP parameters are validated."""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml

from latent_planner_ros.nodes.planner_config import PlannerNodeConfig
from latent_planner_ros.params.config import ConfigError, from_params, to_params
from latent_planner_ros.planning.amp_ls import AmpLsConfig
from latent_planner_ros.planning.amp_ls.config import SearchConfig

REPO = Path(__file__).resolve().parents[2]


def _flatten(d: dict, prefix: str = "") -> dict:
    out = {}
    for k, v in d.items():
        out.update(_flatten(v, f"{prefix}{k}.") if isinstance(v, dict) else {f"{prefix}{k}": v})
    return out


def test_yaml_gives_the_defaults():
    params = _flatten(yaml.safe_load((REPO / "config" / "planner.yaml").read_text())["planner"]["ros__parameters"])
    assert set(params) <= set(to_params(PlannerNodeConfig()))
    config = from_params(PlannerNodeConfig, params)
    assert config == PlannerNodeConfig()
    assert set(to_params(PlannerNodeConfig())) <= set(params)  # the YAML names every parameter
    lspp = config.lspp_config()
    assert lspp.collision_backend == "cylinders" and not lspp.use_orientation
    assert config.amp_ls_config() == AmpLsConfig()  # the default preset with the defaults applied over it


def test_the_node_exposes_under_40_parameters():
    assert len(to_params(PlannerNodeConfig())) < 40


@pytest.mark.parametrize(
    ("name", "value", "message"),
    [
        ("lspp_check", "mesh", "lspp_check must be one of"),
        ("cloud_max_points", 10, "cloud_max_points must be an integer"),
        ("cloud_max_points", 1e5, "cloud_max_points must be an integer"),
        ("cloud_voxel_m", -0.01, "cloud_voxel_m"),
        ("lspp.preset", "default", "lspp.preset must be one of"),
        ("amp_ls.preset", "lspp", "preset must be one of"),
        ("amp_ls.lr", 0.0, "lr must be a positive"),
        ("amp_ls.n_seeds", 0, "amp_ls.n_seeds must be an integer >= 1"),
        ("amp_ls.timeout_s", -1.0, "amp_ls.timeout_s must be a finite number >= 0"),
        ("closed_loop.max_iterations_per_tick", 0, "max_iterations_per_tick must be an integer in"),
        ("closed_loop.max_iterations_per_tick", 2.0, "max_iterations_per_tick must be an integer in"),
        ("tuning_file", "/no/such/file.yaml", "tuning_file '/no/such/file.yaml'"),
    ],
)
def test_bad_values_are_refused_by_name(name, value, message):
    with pytest.raises((ConfigError, ValueError), match=message):
        from_params(PlannerNodeConfig, {name: value})


def _tuned(tmp_path, text: str) -> PlannerNodeConfig:
    path = tmp_path / "tuning.yaml"
    path.write_text(text)
    return from_params(PlannerNodeConfig, {"tuning_file": str(path)})


def test_a_tuning_file_sets_what_the_parameters_do_not(tmp_path):
    config = _tuned(
        tmp_path,
        "amp_ls:\n  search.restarts: 2\n  escape: null\nlspp:\n  checks.backtrace_keep: 0.25\n"
        "closed_loop:\n  plan_wait_s: 0.5\nobstacle_tilt_tol_deg: 3.0\n",
    )
    amp = config.amp_ls_config()
    assert amp.search.restarts == 2 and amp.escape is None and amp.search.n_seeds == 8  # the parameter's
    assert config.lspp_config().checks.backtrace_keep == 0.25
    assert config.closed_loop_config().plan_wait_s == 0.5 and config.closed_loop_config().rate_hz == 10.0
    assert config.tuning.obstacle_tilt_tol_deg == 3.0


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("amp_ls:\n  search.n_seeds: 3\n", "search.n_seeds is set by a parameter of the node"),
        ("closed_loop:\n  rate_hz: 20.0\n", "rate_hz is a parameter of the node"),
        ("closed_loop:\n  warp: 1\n", "unknown ClosedLoopConfig field"),
        ("amp_ls:\n  teleport: 1\n", "unknown AMP-LS field 'teleport'"),
        ("lspp:\n  use_orientation: true\n", "position-only goals"),
        ("obstacle_z_tol_m: 5.0\n", "obstacle_z_tol_m must be a number in"),
        ("colour: red\n", "unknown key"),
        ("- a list\n", "expected a mapping"),
        ("amp_ls: [1, 2\n", "tuning_file"),
    ],
)
def test_a_bad_tuning_file_is_refused_with_the_field(tmp_path, text, message):
    with pytest.raises(ValueError, match=message):
        _tuned(tmp_path, text)


def test_presets_are_chosen_by_name_and_the_parameters_apply_over_them():
    config = from_params(PlannerNodeConfig, {"amp_ls.preset": "seed", "amp_ls.n_seeds": 2, "lspp.preset": "lspp_seed"})
    amp = config.amp_ls_config()
    assert amp.finish is None and amp.escape is None and not amp.checks.lazy  # the seed's Algorithm 1
    assert amp.search.n_seeds == 2 and amp.search.plan_lr == SearchConfig.plan_lr  # the node's parameters over it
    lspp = config.lspp_config()
    assert lspp.search.n_seeds == 1 and lspp.max_steps == 300 and lspp.tau_col == 0.7

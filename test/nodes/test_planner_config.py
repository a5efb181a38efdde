"""PlannerNodeConfig: config/planner.yaml gives the defaults; the obstacle and LSPP parameters are validated."""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml

from latent_planner_ros.nodes.planner_config import PlannerNodeConfig
from sim_bridge.params import ConfigError, from_params, to_params

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
    assert config.lspp.collision_backend == "cylinders" and not config.lspp.use_orientation


@pytest.mark.parametrize(
    ("name", "value", "message"),
    [
        ("lspp_check", "mesh", "lspp_check must be one of"),
        ("obstacle_tilt_tol_deg", -1.0, "obstacle_tilt_tol_deg"),
        ("obstacle_tilt_tol_deg", float("nan"), "obstacle_tilt_tol_deg"),
        ("obstacle_z_tol_m", "0.01", "obstacle_z_tol_m"),
        ("cloud_max_points", 10, "cloud_max_points must be an integer"),
        ("cloud_max_points", 1e5, "cloud_max_points must be an integer"),
        ("cloud_voxel_m", -0.01, "cloud_voxel_m"),
        ("lspp.use_orientation", True, "position-only goals"),
        ("lspp.collision_backend", "learned", "lspp.collision_backend = cylinders"),
        ("lspp.use_collision", False, "lspp.use_collision = true"),
        ("lspp.lr", 0.0, "lr must be a positive"),
        ("closed_loop.accepted_steps_per_tick", 0, "accepted_steps_per_tick must be an integer in"),
        ("closed_loop.accepted_steps_per_tick", 2.0, "accepted_steps_per_tick must be an integer in"),
        ("closed_loop.accepted_steps_per_tick", True, "accepted_steps_per_tick must be an integer in"),
    ],
)
def test_bad_values_are_refused_by_name(name, value, message):
    with pytest.raises((ConfigError, ValueError), match=message):
        from_params(PlannerNodeConfig, {name: value})

"""SimConfig / CameraConfig: validation with reasons, ROS parameter mapping, and config/sim.yaml in sync."""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml

from latent_planner_ros.params.config import ConfigError, from_params, to_params
from sim_bridge.camera_config import CameraConfig
from sim_bridge.sim_config import SimConfig

SIM_YAML = Path(__file__).resolve().parents[2] / "config" / "sim.yaml"


def flatten(tree: dict, prefix: str = "") -> dict:
    out = {}
    for key, value in tree.items():
        if isinstance(value, dict):
            out.update(flatten(value, f"{prefix}{key}."))
        else:
            out[prefix + key] = value
    return out


def test_sim_yaml_matches_the_config_one_to_one():
    params = flatten(yaml.safe_load(SIM_YAML.read_text())["sim"]["ros__parameters"])
    defaults = to_params(SimConfig())
    assert set(params) == set(defaults)
    assert from_params(SimConfig, params) == SimConfig()


def test_params_round_trip():
    config = SimConfig(seed=7, camera=CameraConfig(width=160, position=(1.0, 1.0, 1.0)))
    params = to_params(config)
    assert params["camera.width"] == 160 and params["camera.position"] == [1.0, 1.0, 1.0]
    assert from_params(SimConfig, params) == config


@pytest.mark.parametrize(
    ("params", "message"),
    [
        ({"timestep": 0.0}, "timestep"),
        ({"real_time_factor": -1.0}, "real_time_factor"),
        ({"cloud_rate": 500.0}, "cloud_rate"),
        ({"velocity_scale": 1.5}, "velocity_scale"),
        ({"initial_q": [0.0] * 7}, "initial_q: .* outside the joint limits"),
        ({"initial_q": [0.0] * 6}, "initial_q: expected 7"),
        ({"seed": 1.5}, "seed"),
        ({"scenario": ""}, "scenario"),
        ({"camera.width": 0}, "camera.width"),
        ({"camera.fovy": "wide"}, "camera.fovy"),
        ({"camera.look_at": [1.6, 0.7, 0.0]}, "camera.look_at: the camera must not look straight"),
        ({"camera.crop_max": [-1.0, 0.7, 0.8]}, "camera.crop_max"),
        ({"camera.dropout": 1.0}, "camera.dropout"),
        ({"camera.remove_robot": "yes"}, "camera.remove_robot"),
        ({"camera.zoom": 2}, "camera.zoom: unknown parameter"),
    ],
)
def test_bad_values_are_refused_with_the_parameter_name(params, message):
    with pytest.raises(ConfigError, match=message):
        from_params(SimConfig, params)


def test_partial_update_keeps_the_base():
    base = SimConfig(seed=3)
    updated = from_params(SimConfig, {"real_time_factor": 2}, base=base)
    assert updated.seed == 3 and updated.real_time_factor == 2

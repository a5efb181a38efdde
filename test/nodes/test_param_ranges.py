"""Every range of the parameter descriptors holds at both ends in the config's own validation."""

from __future__ import annotations

import pytest

from latent_planner_ros.nodes import ompl_planner_config, planner_config, scene_encoder_config
from latent_planner_ros.params.config import from_params
from latent_planner_ros.params.specs import param_specs
from sim_bridge.sim_config import SimConfig
from sim_bridge.sim_ranges import SIM_RANGES, SIM_READ_ONLY

CONFIGS = [
    (planner_config.PlannerNodeConfig, planner_config.RANGES, planner_config.READ_ONLY),
    (ompl_planner_config.OmplPlannerNodeConfig, ompl_planner_config.RANGES, ompl_planner_config.READ_ONLY),
    (scene_encoder_config.SceneEncoderNodeConfig, scene_encoder_config.RANGES, scene_encoder_config.READ_ONLY),
    (SimConfig, SIM_RANGES, SIM_READ_ONLY),
]


def _accepts(cls, name, value) -> bool:
    try:
        from_params(cls, {name: value})
    except (ValueError, TypeError):
        return False
    return True


@pytest.mark.parametrize(("cls", "ranges", "read_only"), CONFIGS, ids=lambda c: getattr(c, "__name__", ""))
def test_ranges_match_the_validation(cls, ranges, read_only):
    specs = param_specs(cls(), ranges, read_only)
    checked = 0
    for name, spec in specs.items():
        r = spec.range
        if r is None:
            continue
        integer = spec.type == "integer"
        num = int if integer else float
        eps = 1 if integer else 1e-6 * max(1.0, abs(r.low))
        assert _accepts(cls, name, num(r.low) + eps) or r.high == r.low, name
        assert _accepts(cls, name, num(r.low)) != r.open_low, f"{name} at {r.low}: {r}"
        assert not _accepts(cls, name, num(r.low) - eps), f"{name} below {r}"
        if r.high is not None:
            eps = 1 if integer else 1e-6 * max(1.0, abs(r.high))
            assert _accepts(cls, name, num(r.high)) != r.open_high, f"{name} at {r.high}: {r}"
            assert not _accepts(cls, name, num(r.high) + eps), f"{name} above {r}"
        checked += 1
    assert checked > 5


@pytest.mark.parametrize(("cls", "ranges", "read_only"), CONFIGS, ids=lambda c: getattr(c, "__name__", ""))
def test_every_parameter_but_a_few_has_a_description(cls, ranges, read_only):
    specs = param_specs(cls(), ranges, read_only)
    missing = sorted(n for n, s in specs.items() if not s.description)
    assert all(n.rsplit(".", 1)[-1] in ("lambda_min", "lambda_max") for n in missing), missing

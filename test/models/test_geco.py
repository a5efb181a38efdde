"""The GECO multiplier update follows its rule (seed appendix 6.B.1) on a hand-computed case."""

import math

import numpy as np
import pytest

from latent_planner_ros.models.geco import Geco, GecoConfig


def test_update_matches_the_rule_by_hand():
    g = Geco(GecoConfig(tau=0.5, alpha_ma=0.9, step=0.1, lambda_init=2.0))
    # t = 0: C = 1.5 - 0.5 = 1.0, C_ma = C = 1.0, lambda = 2 * exp(0.1 * 1.0)
    assert g.update(1.5) == pytest.approx(2.0 * math.exp(0.1))
    # t = 1: C = 0.0 - 0.5 = -0.5, C_ma = 0.9 * 1.0 + 0.1 * (-0.5) = 0.85
    assert g.c_ma is not None
    assert g.update(0.0) == pytest.approx(2.0 * math.exp(0.1) * math.exp(0.1 * 0.85))
    assert g.c_ma == pytest.approx(0.85)


def test_multiplier_is_clamped_and_never_overflows():
    g = Geco(GecoConfig(tau=0.0, step=1.0, lambda_init=1.0, lambda_min=1e-3, lambda_max=1e3))
    for _ in range(100):
        g.update(1e6)  # a spike that would overflow exp() if applied directly to lambda
    assert g.value == pytest.approx(1e3)
    for _ in range(10_000):
        g.update(-1e6)
    assert g.value == pytest.approx(1e-3)


def test_scheduled_target_and_state_round_trip():
    g = Geco(GecoConfig(tau=1.0, step=0.5, alpha_ma=0.0))
    g.update(1.0, tau=2.0)  # C = -1
    assert g.value == pytest.approx(math.exp(-0.5))
    h = Geco(GecoConfig(tau=1.0, step=0.5, alpha_ma=0.0))
    h.load_state_dict(g.state_dict())
    assert h.value == g.value and h.c_ma == g.c_ma


def test_bad_config_is_refused():
    with pytest.raises(ValueError):
        GecoConfig(alpha_ma=1.0)
    with pytest.raises(ValueError):
        GecoConfig(lambda_init=0.0)


def test_array_multipliers_update_elementwise_and_scale():
    g = Geco(GecoConfig(tau=1.0, step=1.0, alpha_ma=0.0), shape=(3,))
    out = g.update([1.0, 2.0, 0.0])
    np.testing.assert_allclose(out, np.exp([0.0, 1.0, -1.0]))
    g.scale([0.5, 1.0, 1.0])
    np.testing.assert_allclose(g.value, np.exp([0.0, 1.0, -1.0]) * [0.5, 1.0, 1.0])

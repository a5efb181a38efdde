"""The Wilson interval holds the observed rate, also at 0 and at n successes (where rounding bit a report)."""

import pytest

from latent_planner_ros.evaluation.stats import wilson_ci95


@pytest.mark.parametrize("n", [1, 7, 60, 96, 100, 120, 1000])
def test_the_interval_holds_the_rate_at_every_count(n):
    for k in range(n + 1):
        lo, hi = wilson_ci95(k, n)
        assert 0.0 <= lo <= k / n <= hi <= 1.0
    assert wilson_ci95(n, n)[1] == 1.0 and wilson_ci95(0, n)[0] == 0.0


def test_a_known_interval():
    lo, hi = wilson_ci95(28, 30)
    assert lo == pytest.approx(0.787, abs=1e-3) and hi == pytest.approx(0.982, abs=1e-3)

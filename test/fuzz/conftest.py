"""Hypothesis profiles of the fuzz tests: `fast` (default, in `make test`) and `long` (FUZZ_PROFILE=long).

`bench fuzz` runs the same boundaries with 10,000 inputs each; these profiles keep the tests within a minute.
No example database is written (database=None); the fast profile is derandomised, so CI sees the same inputs.
"""

from __future__ import annotations

import os

from hypothesis import HealthCheck, settings

_COMMON = {
    "database": None,
    "deadline": None,
    "suppress_health_check": [HealthCheck.function_scoped_fixture, HealthCheck.too_slow, HealthCheck.data_too_large],
}
settings.register_profile("fast", max_examples=100, derandomize=True, **_COMMON)
settings.register_profile("long", max_examples=2000, **_COMMON)
settings.load_profile(os.environ.get("FUZZ_PROFILE", "fast"))


def examples(fraction: float) -> settings:
    """Settings with `fraction` of the profile's example count (node callbacks cost more than adapters)."""
    return settings(max_examples=max(5, int(settings.default.max_examples * fraction)))

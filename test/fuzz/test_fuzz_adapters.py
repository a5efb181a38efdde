"""Property-based fuzzing of every adapter that converts an incoming message: no exception but AdapterError
escapes, every refusal names its reason, every accepted result keeps the adapter's contract."""

from __future__ import annotations

import pytest
from hypothesis import given

from latent_planner_ros.bench.fuzz_adapters import ADAPTER_BOUNDARIES


@pytest.mark.parametrize("boundary", ADAPTER_BOUNDARIES, ids=lambda b: b.name)
def test_adapter_boundary(boundary):
    outcomes = []

    @given(boundary.strategy)
    def run(msg):
        outcomes.append(boundary.check(msg))

    run()
    assert outcomes, "no input generated"

"""Property-based fuzzing of each node's subscriber, service and parameter callbacks, called in-process with
generated messages: no exception escapes, every refusal gives its reason (a logged warning naming the adapter's
reason, ~/plan_result, the parameter result), and valid inputs are still handled after the fuzzing."""

from __future__ import annotations

import pytest
import rclpy
from hypothesis import given

from latent_planner_ros.bench.fuzz_nodes import NODE_BOUNDARIES, build
from test.fuzz.conftest import examples

pytestmark = [pytest.mark.ros, pytest.mark.slow]

CASES = [(node, b) for node, names in NODE_BOUNDARIES.items() for b in (*names, "parameters")]


@pytest.fixture(scope="module")
def harnesses():
    rclpy.init()
    built = {}

    def get(node):
        if node not in built:
            built[node] = build(node)
        return built[node]

    yield get
    for fuzz in built.values():
        fuzz.close()
    rclpy.shutdown()


@pytest.mark.parametrize(("node", "boundary"), CASES, ids=[f"{n}.{b}" for n, b in CASES])
def test_node_callback(harnesses, node, boundary):
    fuzz = harnesses(node)
    b = fuzz.all_boundaries()[f"{node}.{boundary}"]
    outcomes = []

    @examples(0.1)
    @given(b.strategy)
    def run(msg):
        outcomes.append(b.check(msg))

    run()
    assert outcomes


@pytest.mark.parametrize("node", list(NODE_BOUNDARIES))
def test_valid_inputs_are_handled_after_the_fuzzing(harnesses, node):
    fuzz = harnesses(node)
    fuzz.restore_parameters()
    fuzz.handles_valid_input()

"""The sim's `<camera>.*` parameter groups behave as the config's parameters: static types and ranges in their
descriptors, integers taken for doubles, refusals that name the full dotted parameter, at start-up and at run time."""

from __future__ import annotations

import pytest
from rclpy.parameter import Parameter

from latent_planner_ros.params.config import ConfigError
from test.nodes.sim_node import make_sim, running_sim

pytestmark = pytest.mark.ros


def _sim(*args: str):
    return make_sim("-p", "cameras:=[camera, front]", *args)


@pytest.fixture
def sim():
    with running_sim("-p", "cameras:=[camera, front]", "-p", "front.rate:=5") as node:  # an int for a double
        yield node


def _set(node, name, value):
    return node.set_parameters([Parameter(name, value=value)])[0]


def test_camera_groups_have_the_descriptors_of_camera(sim):
    d = sim.describe_parameter("front.rate")
    assert not d.dynamic_typing and d.type == Parameter.Type.DOUBLE.value
    assert d.additional_constraints == "valid range [0, 100]" and d.description
    assert (d.floating_point_range[0].from_value, d.floating_point_range[0].to_value) == (0.0, 100.0)
    assert sim.describe_parameter("front.width").integer_range[0].to_value == 1280
    assert sim.get_parameter("front.rate").type_ == Parameter.Type.DOUBLE
    assert sim.named_cameras["front"].rate == 5.0


@pytest.mark.parametrize(
    "name, value, reason",
    [
        ("front.rate", "fast", "front.rate: expected double, got string 'fast'"),
        ("front.rate", True, "front.rate: expected double, got bool True"),
        ("front.width", 2.5, "front.width: expected integer, got double 2.5"),
        ("front.position", ["a", "b", "c"], "front.position: expected double[], got string[]"),
        ("front.rate", 200.0, "Parameter front.rate out of range"),
        ("front.width", 5, "Parameter front.width out of range"),
        ("front.fovy", 0.5, "Parameter front.fovy out of range"),
        ("front.position", [1.0, 2.0], "front.position: expected 3 finite numbers"),
        ("front.max_depth", 0.01, "front.max_depth: expected a number in"),
    ],
)
def test_bad_camera_values_are_refused_by_their_dotted_name(sim, name, value, reason):
    before = sim.named_cameras["front"]
    r = _set(sim, name, value)
    assert not r.successful and r.reason.startswith(reason), r.reason
    assert sim.named_cameras["front"] == before


def test_good_camera_values_are_applied(sim):
    assert _set(sim, "front.rate", 20).successful  # an integer for a double
    assert sim.get_parameter("front.rate").type_ == Parameter.Type.DOUBLE
    assert _set(sim, "front.position", [0.4, -1.1, 1.0]).successful
    front = sim.named_cameras["front"]
    assert front.rate == 20.0 and front.position == (0.4, -1.1, 1.0)
    assert sim.config.camera.rate != 20.0  # the camera group is the front camera's alone


@pytest.mark.parametrize(
    "args, message",
    [
        (["-p", "front.rate:=fast"], "front.rate: expected double, got string 'fast'"),
        (["-p", "front.rate:=500.0"], "front.rate: 500.0 is outside its valid range [0, 100]"),
    ],
)
def test_bad_camera_values_at_start_up_name_the_parameter(args, message):
    with pytest.raises(ConfigError, match=message.replace("[", r"\[").replace("]", r"\]")):
        _sim(*args)  # shuts its context down

"""Message definitions as rosbag2 writes them: every type the suite publishes, read by rosbags' own parser."""

from __future__ import annotations

import pytest
from rosbags.typesys import Stores, get_types_from_msg, get_typestore

from latent_planner_ros.recording.msgdef import DELIMITER, MessageDefinitionError, message_definition

SUITE_TYPES = (
    "sensor_msgs/msg/JointState",
    "sensor_msgs/msg/PointCloud2",
    "geometry_msgs/msg/PoseStamped",
    "trajectory_msgs/msg/JointTrajectory",
    "diagnostic_msgs/msg/DiagnosticArray",
    "diagnostic_msgs/msg/DiagnosticStatus",
    "visualization_msgs/msg/MarkerArray",
    "rosgraph_msgs/msg/Clock",
    "std_msgs/msg/Bool",
    "std_msgs/msg/Float64",
    "std_msgs/msg/Header",
    "std_msgs/msg/String",
    "nav_msgs/msg/Path",
)


def _split(text: str) -> dict[str, str]:
    """{type: its own .msg text} of a schema text."""
    first, *rest = text.split(DELIMITER + "\n")
    out = {"": first}
    for block in rest:
        header, _, body = block.partition("\n")
        assert header.startswith("MSG: "), header
        out[header.removeprefix("MSG: ")] = body
    return out


@pytest.mark.parametrize("type_name", SUITE_TYPES)
def test_definitions_parse_to_the_fields_rosbags_knows(type_name):
    """rosbags parses our schema text into exactly the types (and field names) of its built-in Jazzy store."""
    reference = get_typestore(Stores.ROS2_JAZZY)
    parsed = get_types_from_msg(message_definition(type_name), type_name)
    for dep, body in _split(message_definition(type_name)).items():
        if dep:
            parsed.update(get_types_from_msg(body, dep))
    assert type_name in parsed
    for name, (_, fields) in parsed.items():
        ref_fields = reference.fielddefs[name][1]
        assert [f[0] for f in fields] == [f[0] for f in ref_fields], name


def test_every_dependency_is_listed_once_and_nested_ones_too():
    parts = _split(message_definition("visualization_msgs/msg/MarkerArray"))
    deps = [k for k in parts if k]
    assert len(deps) == len(set(deps))
    # MarkerArray -> Marker -> Header -> builtin_interfaces/Time, and Marker -> MeshFile (nested, not direct)
    for dep in ("visualization_msgs/msg/Marker", "std_msgs/msg/Header", "builtin_interfaces/msg/Time"):
        assert dep in deps
    assert "visualization_msgs/msg/MeshFile" in deps


def test_unknown_and_malformed_types_are_refused():
    with pytest.raises(MessageDefinitionError, match="no_such_msgs"):
        message_definition("no_such_msgs/msg/Nothing")
    with pytest.raises(MessageDefinitionError, match="package/msg/Type"):
        message_definition("JointState")

"""ROS 2 message definitions as rosbag2 writes them into MCAP schemas (encoding ``ros2msg``). No ROS here.

The text of a type is its ``.msg`` file followed by the ``.msg`` file of every type it uses, depth first, each
after a line of 80 ``=`` and a ``MSG: <package>/msg/<Type>`` line (the layout of rosbag2's
message_definition_cache, which ``ros2 bag``, rosbags and Foxglove read). The ``.msg`` files are those the message
packages install under ``<prefix>/share/<package>/msg/`` (``$AMENT_PREFIX_PATH``, then ``sys.prefix``).

    text = message_definition("sensor_msgs/msg/JointState")
"""

from __future__ import annotations

import os
import re
import sys
from functools import cache
from pathlib import Path

PRIMITIVES = frozenset(
    "bool byte char float32 float64 int8 uint8 int16 uint16 int32 uint32 int64 uint64 string wstring".split()
)
DELIMITER = "=" * 80
_TYPE = re.compile(r"^([A-Za-z0-9_/]+?)(?:<=\d+)?(?:\[[^\]]*\])?$")


class MessageDefinitionError(LookupError):
    """A type whose ``.msg`` file is not installed, or a malformed type name."""


def prefixes() -> list[Path]:
    """Install prefixes searched for ``share/<package>/msg``: ``$AMENT_PREFIX_PATH``, then ``sys.prefix``."""
    dirs = [Path(p) for p in os.environ.get("AMENT_PREFIX_PATH", "").split(os.pathsep) if p]
    return list(dict.fromkeys([*dirs, Path(sys.prefix)]))


def split_type(type_name: str) -> tuple[str, str]:
    """``"sensor_msgs/msg/JointState"`` or ``"sensor_msgs/JointState"`` -> ``("sensor_msgs", "JointState")``."""
    parts = type_name.split("/")
    if len(parts) == 3 and parts[1] == "msg":
        parts = [parts[0], parts[2]]
    if len(parts) != 2 or not all(parts):
        raise MessageDefinitionError(f"not a message type name: {type_name!r} (expected package/msg/Type)")
    return parts[0], parts[1]


@cache
def msg_file_text(type_name: str) -> str:
    """The ``.msg`` file of a type; MessageDefinitionError if no prefix installs it."""
    package, name = split_type(type_name)
    for prefix in prefixes():
        path = prefix / "share" / package / "msg" / f"{name}.msg"
        if path.is_file():
            return path.read_text()
    raise MessageDefinitionError(f"no {package}/msg/{name}.msg under {', '.join(str(p) for p in prefixes())}")


def field_types(text: str, package: str) -> list[str]:
    """The non-primitive types (``package/msg/Type``) of the fields of a ``.msg`` text, in order of appearance;
    constants and comments are skipped, a type without package is in `package`."""
    out = []
    for line in text.splitlines():
        line = line.split("#", 1)[0].strip()
        if not line:
            continue
        type_token, _, rest = line.partition(" ")
        if "=" in rest.split(" ", 1)[0] or re.match(r"^\s*[A-Z0-9_]+\s*=", rest):  # a constant
            continue
        match = _TYPE.match(type_token)
        if match is None:
            raise MessageDefinitionError(f"cannot read the field type {type_token!r} in {package}")
        base = match.group(1)
        if base in PRIMITIVES:
            continue
        if base == "Header":
            base = "std_msgs/Header"
        pkg, name = split_type(base) if "/" in base else (package, base)
        out.append(f"{pkg}/msg/{name}")
    return out


@cache
def message_definition(type_name: str) -> str:
    """The rosbag2 ``ros2msg`` schema text of a type (see the module docstring)."""
    package, name = split_type(type_name)
    root = f"{package}/msg/{name}"
    order: list[str] = []

    def visit(t: str) -> None:
        pkg, _ = split_type(t)
        for dep in field_types(msg_file_text(t), pkg):
            if dep not in order and dep != root:
                order.append(dep)
                visit(dep)

    visit(root)
    parts = [msg_file_text(root).rstrip("\n") + "\n"]
    for dep in order:
        parts.append(f"{DELIMITER}\nMSG: {dep}\n{msg_file_text(dep).rstrip(chr(10))}\n")
    return "".join(parts)

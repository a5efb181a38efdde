"""The Panda URDF (example-robot-data) as XML text for `robot_description`, with a joint/link name prefix. No ROS.

The shipped URDF names its links and joints `panda_*` (`panda_link0`, `panda_joint1`, `panda_hand_tcp`); a prefix
such as `fr3_` replaces that `panda_` in every link and joint name and in every reference to one (parent, child,
mimic), so robot_state_publisher publishes TF frames matching the joint names of `joint_states`. Meshes stay
`package://example-robot-data/...` URIs (RViz resolves them on a ROS install with example-robot-data).
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from functools import cache

from latent_planner_ros.robot.description import panda_description

PANDA_PREFIX = "panda_"

_REFERENCES = (("link", "name"), ("joint", "name"), ("parent", "link"), ("child", "link"), ("mimic", "joint"))
"""(element, attribute) pairs holding a link or joint name."""


@cache
def panda_urdf(prefix: str = PANDA_PREFIX) -> str:
    """URDF XML of the Panda whose link and joint names start with `prefix` instead of `panda_`.

    Raises:
        FileNotFoundError: example-robot-data is not installed.
    """
    root = ET.parse(panda_description().urdf).getroot()
    if prefix != PANDA_PREFIX:
        for tag, attribute in _REFERENCES:
            for element in root.iter(tag):
                name = element.get(attribute)
                if name and name.startswith(PANDA_PREFIX):
                    element.set(attribute, prefix + name[len(PANDA_PREFIX) :])
    return ET.tostring(root, encoding="unicode", xml_declaration=True)

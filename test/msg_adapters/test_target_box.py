"""The grasp target box as a CUBE marker: taken, cleared, refused with the reason."""

from __future__ import annotations

import numpy as np
import pytest
from visualization_msgs.msg import Marker

from msg_adapters import AdapterError, box_to_marker, marker_to_box


def test_a_cube_marker_gives_its_pose_and_half_extents_and_round_trips():
    msg = box_to_marker(np.array([0.6, 0.0, 0.23]), np.array([0.0, 0.0, 0.0, 1.0]), np.array([0.03, 0.02, 0.08]))
    msg.header.frame_id = "panda_link0"
    pose, half = marker_to_box(msg)
    assert pose.header.frame_id == "panda_link0"
    assert (pose.pose.position.x, pose.pose.position.y, pose.pose.position.z) == (0.6, 0.0, 0.23)
    np.testing.assert_allclose(half, [0.03, 0.02, 0.08])


@pytest.mark.parametrize("action", [Marker.DELETE, Marker.DELETEALL])
def test_delete_and_deleteall_clear_the_box(action):
    assert marker_to_box(Marker(action=action)) is None


@pytest.mark.parametrize(
    ("change", "words"),
    [
        ({"type": Marker.SPHERE}, "is not CUBE"),
        ({"action": 7}, "is not ADD, DELETE or DELETEALL"),
        ({"scale": (0.0, 0.1, 0.1)}, "edges must be lengths"),
        ({"scale": (float("nan"), 0.1, 0.1)}, "edges must be lengths"),
        ({"scale": (3.0, 0.1, 0.1)}, "edges must be lengths"),
    ],
)
def test_a_bad_marker_is_refused_with_the_reason(change, words):
    msg = box_to_marker(np.zeros(3), np.array([0.0, 0.0, 0.0, 1.0]), np.full(3, 0.05))
    if "scale" in change:
        msg.scale.x, msg.scale.y, msg.scale.z = change.pop("scale")
    for key, value in change.items():
        setattr(msg, key, value)
    with pytest.raises(AdapterError, match=words):
        marker_to_box(msg)

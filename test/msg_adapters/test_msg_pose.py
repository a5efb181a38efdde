"""msg_adapters.pose: PoseStamped <-> PoseTarget round trips, normalisation and refusals."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from builtin_interfaces.msg import Time
from geometry_msgs.msg import PoseStamped

from msg_adapters import AdapterError, PoseTarget, pose_stamped_to_target, target_to_pose_stamped


def _reference_matrix(q_xyzw: np.ndarray) -> np.ndarray:
    """Rotation matrix of a unit quaternion, written out (independent of the code under test)."""
    x, y, z, w = q_xyzw
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )


def _pose(position, quat_xyzw, frame="world") -> PoseStamped:
    msg = PoseStamped()
    msg.header.frame_id = frame
    msg.pose.position.x, msg.pose.position.y, msg.pose.position.z = (float(v) for v in position)
    o = msg.pose.orientation
    o.x, o.y, o.z, o.w = (float(v) for v in quat_xyzw)
    return msg


def test_round_trip_random(rng):
    """200 random poses with unnormalised quaternions of either sign."""
    for _ in range(200):
        position = rng.uniform(-1.5, 1.5, size=3)
        quat = rng.normal(size=4) * rng.uniform(0.01, 10.0)
        unit = quat / np.linalg.norm(quat)
        msg = target_to_pose_stamped(position, quat, stamp=Time(sec=5))
        assert msg.header.frame_id == "world" and msg.header.stamp == Time(sec=5)
        target = pose_stamped_to_target(msg)
        assert isinstance(target, PoseTarget) and target.frame_id == "world"
        np.testing.assert_allclose(target.position, position, atol=0)
        np.testing.assert_allclose(target.quaternion_xyzw, unit, atol=1e-12)
        assert abs(np.linalg.norm(target.quaternion_xyzw) - 1.0) < 1e-12
        np.testing.assert_allclose(target.rotation, _reference_matrix(unit), atol=1e-9)
        np.testing.assert_allclose(target.rotation @ target.rotation.T, np.eye(3), atol=1e-9)
        np.testing.assert_allclose(target.rot6d, np.concatenate([target.rotation[:, 0], target.rotation[:, 1]]))
        assert target.position.shape == (3,) and target.rot6d.shape == (6,) and target.rotation.shape == (3, 3)


def test_unnormalised_message_quaternion_is_normalised():
    target = pose_stamped_to_target(_pose([0.5, 0, 0.3], [0, 0, 0, 2.0]))
    np.testing.assert_array_equal(target.quaternion_xyzw, [0, 0, 0, 1])
    np.testing.assert_allclose(target.rotation, np.eye(3), atol=1e-15)


def test_target_is_immutable():
    target = pose_stamped_to_target(_pose([0.5, 0, 0.3], [0, 0, 0, 1]))
    with pytest.raises(dataclasses.FrozenInstanceError):
        target.frame_id = "other"  # type: ignore[misc]
    with pytest.raises(ValueError, match="read-only"):
        target.position[0] = 1.0


def test_empty_frame_means_expected_frame():
    assert pose_stamped_to_target(_pose([0, 0, 0], [0, 0, 0, 1], frame="")).frame_id == "world"
    assert pose_stamped_to_target(_pose([0, 0, 0], [0, 0, 0, 1], frame=""), expected_frame="base").frame_id == "base"


def test_any_frame_when_expected_frame_is_none():
    assert pose_stamped_to_target(_pose([0, 0, 0], [0, 0, 0, 1], frame="camera"), expected_frame=None).frame_id == (
        "camera"
    )
    assert pose_stamped_to_target(_pose([0, 0, 0], [0, 0, 0, 1], frame=""), expected_frame=None).frame_id == ""


def test_refuses_wrong_frame():
    with pytest.raises(AdapterError, match="frame_id is 'camera', expected 'world'"):
        pose_stamped_to_target(_pose([0, 0, 0], [0, 0, 0, 1], frame="camera"))


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
@pytest.mark.parametrize("axis", [0, 1, 2])
def test_refuses_non_finite_position(bad, axis):
    position = np.zeros(3)
    position[axis] = bad
    with pytest.raises(AdapterError, match="position has NaN or inf"):
        pose_stamped_to_target(_pose(position, [0, 0, 0, 1]))


@pytest.mark.parametrize("bad", [np.nan, np.inf])
def test_refuses_non_finite_orientation(bad):
    with pytest.raises(AdapterError, match="orientation has NaN or inf"):
        pose_stamped_to_target(_pose([0, 0, 0], [0, bad, 0, 1]))


@pytest.mark.parametrize("quat", [[0, 0, 0, 0], [1e-12, 0, 0, 0]])
def test_refuses_zero_quaternion(quat):
    with pytest.raises(AdapterError, match="zero norm"):
        pose_stamped_to_target(_pose([0, 0, 0], quat))


@pytest.mark.parametrize(
    ("position", "quat", "match"),
    [
        ([0, 0], [0, 0, 0, 1], r"position: expected shape \(3\)"),
        ([0, 0, np.nan], [0, 0, 0, 1], "position: contains NaN"),
        ([0, 0, 0], [0, 0, 1], "expected 4 components"),
        ([0, 0, 0], [0, 0, 0, 0], "zero norm"),
        ([0, 0, 0], [np.inf, 0, 0, 1], "NaN or inf"),
    ],
)
def test_target_to_pose_stamped_refuses(position, quat, match):
    with pytest.raises(AdapterError, match=match):
        target_to_pose_stamped(position, quat)

"""msg_adapters.cylinder_markers: CYLINDER markers <-> (x, y, h, r), the RViz (ns, id) semantics, refusals."""

from __future__ import annotations

import math

import numpy as np
import pytest
from visualization_msgs.msg import Marker, MarkerArray

from msg_adapters import AdapterError, apply_marker_array, cylinders_to_array, cylinders_to_marker_array


def _cylinder(x=0.5, y=0.1, h=0.4, r=0.05, ns="obs", id_=0, frame="world", z=None, quat=(0.0, 0.0, 0.0, 1.0)):
    m = Marker(ns=ns, id=id_, type=Marker.CYLINDER, action=Marker.ADD)
    m.header.frame_id = frame
    m.pose.position.x, m.pose.position.y = x, y
    m.pose.position.z = h / 2.0 if z is None else z
    o = m.pose.orientation
    o.x, o.y, o.z, o.w = quat
    m.scale.x = m.scale.y = 2.0 * r
    m.scale.z = h
    return m


def _array(*markers) -> MarkerArray:
    return MarkerArray(markers=list(markers))


def test_one_cylinder():
    up = apply_marker_array(_array(_cylinder(0.5, -0.2, 0.6, 0.04)))
    np.testing.assert_allclose(cylinders_to_array(up.cylinders), [[0.5, -0.2, 0.6, 0.04]])
    assert up.notes == () and not up.cleared


def test_round_trip_random(rng):
    """Random sets survive cylinders -> markers -> cylinders (ordered by id)."""
    for _ in range(20):
        k = int(rng.integers(1, 6))
        cyl = np.column_stack([rng.uniform(-0.8, 0.8, (k, 2)), rng.uniform(0.1, 1.0, k), rng.uniform(0.03, 0.1, k)])
        up = apply_marker_array(cylinders_to_marker_array(cyl))
        np.testing.assert_allclose(cylinders_to_array(up.cylinders), cyl, atol=1e-12)


@pytest.mark.parametrize("frame", ["world", "panda_link0", ""])
def test_accepted_frames(frame):
    assert len(apply_marker_array(_array(_cylinder(frame=frame))).cylinders) == 1


def test_rotation_about_vertical_and_small_tilt_accepted():
    yaw = (0.0, 0.0, math.sin(0.6), math.cos(0.6))  # 1.2 rad about z: a cylinder looks the same
    tilt = (math.sin(math.radians(0.5)), 0.0, 0.0, math.cos(math.radians(0.5)))  # 1 deg about x
    unnormalised = (0.0, 0.0, 0.0, 3.0)
    up = apply_marker_array(
        _array(_cylinder(id_=0, quat=yaw), _cylinder(id_=1, quat=tilt), _cylinder(id_=2, quat=unnormalised))
    )
    assert len(up.cylinders) == 3


@pytest.mark.parametrize(
    ("marker", "match"),
    [
        (_cylinder(x=float("nan")), "NaN or inf"),
        (_cylinder(r=float("inf")), "NaN or inf"),
        (_cylinder(h=0.0, z=0.0), "scale must be positive"),
        (_cylinder(r=-0.05), "scale must be positive"),
        (_cylinder(frame="camera"), "frame_id 'camera'"),
        (_cylinder(quat=(math.sin(0.2), 0.0, 0.0, math.cos(0.2))), "tilted 22.9 deg"),
        (_cylinder(quat=(0.0, 0.0, 0.0, 0.0)), "zero norm"),
        (_cylinder(h=0.4, z=0.0), "stand on the table"),
    ],
)
def test_refused(marker, match):
    before = {("obs", 7): np.array([0.4, 0.0, 0.3, 0.05])}
    with pytest.raises(AdapterError, match=match):
        apply_marker_array(_array(_cylinder(id_=1), marker), before)
    assert list(before) == [("obs", 7)]  # the caller's set is untouched


def test_unequal_diameters_refused():
    m = _cylinder()
    m.scale.y = m.scale.x + 0.02
    with pytest.raises(AdapterError, match="must be equal"):
        apply_marker_array(_array(m))


def test_unknown_action_refused():
    m = _cylinder()
    m.action = 7
    with pytest.raises(AdapterError, match="unknown action 7"):
        apply_marker_array(_array(m))


def test_keyed_add_replace_delete_deleteall():
    up = apply_marker_array(_array(_cylinder(id_=0), _cylinder(id_=1, x=0.3), _cylinder(ns="b", id_=0, x=-0.4)))
    assert len(up.cylinders) == 3
    up = apply_marker_array(_array(_cylinder(id_=1, x=0.35)), up.cylinders)  # same (ns, id): replaced
    assert len(up.cylinders) == 3 and up.cylinders[("obs", 1)][0] == pytest.approx(0.35)
    delete = Marker(ns="obs", id=0, action=Marker.DELETE)
    up = apply_marker_array(_array(delete), up.cylinders)
    assert sorted(up.cylinders) == [("b", 0), ("obs", 1)]
    up = apply_marker_array(_array(Marker(action=Marker.DELETEALL)), up.cylinders)
    assert up.cylinders == {} and up.cleared
    assert cylinders_to_array(up.cylinders).shape == (0, 4)
    # DELETEALL then ADD in one array replaces the whole set
    up = apply_marker_array(_array(Marker(action=Marker.DELETEALL), _cylinder(id_=4)), {("x", 1): np.ones(4)})
    assert list(up.cylinders) == [("obs", 4)] and up.cleared


def test_other_types_ignored_with_a_note():
    sphere = Marker(ns="obs", id=9, type=Marker.SPHERE, action=Marker.ADD)
    sphere.pose.position.x = float("nan")  # not read: ignored markers are never refused
    up = apply_marker_array(_array(sphere, _cylinder()))
    assert len(up.cylinders) == 1
    assert up.notes == ("ignored markers that are not CYLINDER: 1 SPHERE",)


def test_lifetime_noted():
    m = _cylinder()
    m.lifetime.sec = 2
    assert "lifetime ignored" in apply_marker_array(_array(m)).notes[0]


def test_published_markers_delete_the_previous_surplus():
    msg = cylinders_to_marker_array(np.array([[0.5, 0.0, 0.4, 0.05]]), previous=3)
    assert [(m.id, m.action) for m in msg.markers] == [(0, Marker.ADD), (1, Marker.DELETE), (2, Marker.DELETE)]
    m = msg.markers[0]
    assert m.type == Marker.CYLINDER and m.pose.position.z == pytest.approx(0.2) and m.scale.x == pytest.approx(0.1)
    assert cylinders_to_marker_array(np.zeros((0, 4))).markers == []
    with pytest.raises(AdapterError, match="positive"):
        cylinders_to_marker_array(np.array([[0.5, 0.0, -0.4, 0.05]]))
    with pytest.raises(AdapterError, match="NaN"):
        cylinders_to_marker_array(np.array([[np.nan, 0.0, 0.4, 0.05]]))

"""visualization_msgs/MarkerArray <-> state-based cylinder obstacles o = (x, y, h, r) [m] (LSPP).

A cylinder obstacle stands upright on the table (z = 0) with height h and radius r, its axis at (x, y). As a
CYLINDER marker: pose.position = (x, y, h / 2) (RViz draws a cylinder centred at its pose, so a marker drawn
standing on the table has z = h / 2; any other z is refused rather than silently moved), scale = (2r, 2r, h),
orientation upright (any rotation about the vertical axis; a tilted axis is refused), frame `world` or
`panda_link0` (the same frame) or empty (taken as `world`).

A MarkerArray is applied in order onto the current set, keyed by (ns, id) as RViz does: ADD (= MODIFY) adds
or replaces, DELETE removes, DELETEALL clears. Markers are latched state: `lifetime` is ignored. Markers of
other types are ignored (with a note); one refused marker refuses the whole array, so the caller keeps its
last valid set.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
from builtin_interfaces.msg import Time
from visualization_msgs.msg import Marker, MarkerArray

from msg_adapters._common import as_float_array, stamp_or_zero
from msg_adapters.errors import AdapterError

CylinderKey = tuple[str, int]
"""(ns, id) of a marker"""

OBSTACLE_FRAMES = ("world", "panda_link0", "")
"""frames accepted for obstacle markers (the Panda base frame is `world`; empty means `world`)"""

_TYPE_NAMES = {
    getattr(Marker, n): n
    for n in (
        "ARROW",
        "CUBE",
        "SPHERE",
        "CYLINDER",
        "LINE_STRIP",
        "LINE_LIST",
        "CUBE_LIST",
        "SPHERE_LIST",
        "POINTS",
        "TEXT_VIEW_FACING",
        "MESH_RESOURCE",
        "TRIANGLE_LIST",
        "ARROW_STRIP",
    )
    if hasattr(Marker, n)
}


@dataclass(frozen=True)
class CylinderUpdate:
    """The obstacle set after one MarkerArray.

    cylinders: {(ns, id): (4,) float64 (x, y, h, r) [m]}, a new dict (the input is not changed).
    notes: what was ignored (other marker types, lifetimes), for a status topic.
    cleared: the array contained a DELETEALL.
    """

    cylinders: dict[CylinderKey, np.ndarray]
    notes: tuple[str, ...]
    cleared: bool


def _marker_cylinder(m: Marker, tilt_tol_deg: float, z_tol_m: float) -> np.ndarray:
    """(x, y, h, r) [m] of one CYLINDER marker with action ADD; AdapterError naming the problem."""
    what = f"cylinder marker ns={m.ns!r} id={m.id}"
    if m.header.frame_id not in OBSTACLE_FRAMES:
        raise AdapterError(f"{what}: frame_id {m.header.frame_id!r}, expected 'world' or 'panda_link0'")
    p, s, o = m.pose.position, m.scale, m.pose.orientation
    values = np.array([p.x, p.y, p.z, s.x, s.y, s.z, o.x, o.y, o.z, o.w], dtype=np.float64)
    if not np.all(np.isfinite(values)):
        raise AdapterError(f"{what}: position, scale or orientation has NaN or inf")
    if min(s.x, s.y, s.z) <= 0.0:
        raise AdapterError(f"{what}: scale must be positive (diameter x, y and height z), got {s.x}, {s.y}, {s.z}")
    if abs(s.x - s.y) > 1e-3:
        raise AdapterError(f"{what}: scale.x and scale.y (diameters) must be equal, got {s.x} and {s.y}")
    norm = math.hypot(o.x, o.y, o.z, o.w)  # hypot: no overflow for huge components (1e200 ** 2 raises)
    if norm < 1e-9:
        raise AdapterError(f"{what}: orientation quaternion has zero norm")
    # the marker's axis is the rotated z axis; its world z component is R[2, 2] = 1 - 2 (x^2 + y^2) (unit q)
    cos_tilt = 1.0 - 2.0 * (math.hypot(o.x, o.y) / norm) ** 2
    tilt_deg = math.degrees(math.acos(min(1.0, max(-1.0, cos_tilt))))
    if tilt_deg > tilt_tol_deg:
        raise AdapterError(f"{what}: axis tilted {tilt_deg:.1f} deg from vertical (at most {tilt_tol_deg} deg)")
    if abs(p.z - s.z / 2.0) > z_tol_m:
        raise AdapterError(
            f"{what}: pose.position.z = {p.z:.3f} m, expected scale.z / 2 = {s.z / 2.0:.3f} m "
            "(obstacle cylinders stand on the table at z = 0)"
        )
    return np.array([p.x, p.y, s.z, s.x / 2.0], dtype=np.float64)


def apply_marker_array(
    msg: MarkerArray,
    current: Mapping[CylinderKey, np.ndarray] | None = None,
    tilt_tol_deg: float = 2.0,
    z_tol_m: float = 0.01,
) -> CylinderUpdate:
    """Apply a MarkerArray's markers, in order, to the `current` cylinder set.

    Args:
        msg: the markers.
        current: {(ns, id): (4,) (x, y, h, r) [m]}, the set before this array (None = empty).
        tilt_tol_deg: largest angle [deg] between a cylinder's axis and the vertical.
        z_tol_m: largest difference [m] between pose.position.z and scale.z / 2.

    Raises:
        AdapterError: a CYLINDER marker to add with a bad frame, NaN/inf, non-positive or unequal diameters,
            a tilted axis or a z off the table; or an unknown action. Nothing is applied then.
    """
    cylinders = {k: np.asarray(v, dtype=np.float64) for k, v in (current or {}).items()}
    ignored: dict[str, int] = {}
    lifetimes = 0
    cleared = False
    for m in msg.markers:
        key = (m.ns, int(m.id))
        if m.action == Marker.DELETEALL:
            cylinders.clear()
            cleared = True
        elif m.action == Marker.DELETE:
            cylinders.pop(key, None)
        elif m.action != Marker.ADD:
            raise AdapterError(f"marker ns={m.ns!r} id={m.id}: unknown action {m.action}")
        elif m.type != Marker.CYLINDER:
            name = _TYPE_NAMES.get(m.type, str(m.type))
            ignored[name] = ignored.get(name, 0) + 1
        else:
            cylinders[key] = _marker_cylinder(m, tilt_tol_deg, z_tol_m)
            lifetimes += m.lifetime.sec != 0 or m.lifetime.nanosec != 0
    notes = []
    if ignored:
        kinds = ", ".join(f"{n} {name}" for name, n in sorted(ignored.items()))
        notes.append(f"ignored markers that are not CYLINDER: {kinds}")
    if lifetimes:
        notes.append(f"lifetime ignored on {lifetimes} cylinder marker(s): obstacles stay until DELETE/DELETEALL")
    return CylinderUpdate(cylinders=cylinders, notes=tuple(notes), cleared=cleared)


def cylinders_to_array(cylinders: Mapping[CylinderKey, np.ndarray]) -> np.ndarray:
    """The set as a (K, 4) float64 array of (x, y, h, r) [m], ordered by (ns, id); (0, 4) when empty."""
    if not cylinders:
        return np.zeros((0, 4))
    return np.stack([np.asarray(cylinders[k], dtype=np.float64) for k in sorted(cylinders)])


def cylinders_to_marker_array(
    cylinders: np.ndarray,
    frame_id: str = "world",
    stamp: Time | None = None,
    ns: str = "obstacles",
    previous: int = 0,
    rgba: tuple[float, float, float, float] = (0.9, 0.5, 0.1, 0.6),
) -> MarkerArray:
    """CYLINDER markers (ids 0..K-1 in namespace `ns`) of cylinders (K, 4) (x, y, h, r) [m], standing on z = 0.

    previous: how many markers of `ns` were published before; ids K..previous-1 get a DELETE, so a shrinking
    set leaves nothing behind in RViz (a DELETEALL would also clear other namespaces).

    Raises:
        AdapterError: not a (K, 4) finite array, or non-positive heights or radii.
    """
    arr = as_float_array(cylinders if np.size(cylinders) else np.zeros((0, 4)), (None, 4), "cylinders")
    if np.any(arr[:, 2:] <= 0.0):
        raise AdapterError("cylinders: heights and radii must be positive")
    stamp = stamp_or_zero(stamp)
    markers = []
    for i, (x, y, h, r) in enumerate(arr):
        m = Marker(ns=ns, id=i, type=Marker.CYLINDER, action=Marker.ADD)
        m.header.frame_id, m.header.stamp = frame_id, stamp
        m.pose.position.x, m.pose.position.y, m.pose.position.z = float(x), float(y), float(h) / 2.0
        m.pose.orientation.w = 1.0
        m.scale.x = m.scale.y = 2.0 * float(r)
        m.scale.z = float(h)
        m.color.r, m.color.g, m.color.b, m.color.a = rgba
        markers.append(m)
    for i in range(len(arr), previous):
        m = Marker(ns=ns, id=i, action=Marker.DELETE)
        m.header.frame_id, m.header.stamp = frame_id, stamp
        markers.append(m)
    return MarkerArray(markers=markers)

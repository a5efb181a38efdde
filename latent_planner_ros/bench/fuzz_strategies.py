"""Hypothesis strategies for the messages the nodes take in: valid ones, near misses and garbage.

Each strategy mixes three kinds of values: plausible ones (so deep code paths are reached), near misses (one field
wrong: a truncated PointCloud2, a duplicate joint name, a NaN) and garbage (any float, any length, any frame).
Large arrays are drawn as a size and a seed (numpy fills them), so a 300k-point cloud costs milliseconds.
Used by test/fuzz (fast profile) and `bench fuzz` (long profile).
"""

from __future__ import annotations

import numpy as np
from builtin_interfaces.msg import Duration, Time
from geometry_msgs.msg import PoseStamped
from hypothesis import strategies as st
from nav_msgs.srv import GetPlan
from rclpy.parameter import Parameter
from sensor_msgs.msg import JointState, PointCloud2, PointField
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint
from visualization_msgs.msg import Marker, MarkerArray

from latent_planner_ros.robot.limits import JOINT_NAMES, Q_READY
from msg_adapters import embedding_to_cloud, xyz_to_cloud

INT32 = st.integers(-(2**31), 2**31 - 1)
UINT32 = st.integers(0, 2**32 - 1)
SPECIAL = (float("nan"), float("inf"), -float("inf"), 1e308, -1e308, 1e200, 1e-310, 0.0, -0.0)
ANY_FLOAT = st.floats(allow_nan=True, allow_infinity=True) | st.sampled_from(SPECIAL)
"""any float64: NaN, +-inf, huge, subnormal, signed zero"""


def floats(low: float = -2.0, high: float = 2.0) -> st.SearchStrategy[float]:
    """Mostly plausible values in [low, high], sometimes any float."""
    return st.one_of(*[st.floats(low, high)] * 4, ANY_FLOAT)


FRAMES = st.one_of(
    st.just("world"),
    st.just("world"),
    st.sampled_from(["world", "", "panda_link0", "camera_depth_optical_frame", "map", "fr3_link0", " world"]),
    st.text(max_size=16),
)
NAMES = st.one_of(
    st.sampled_from([*JOINT_NAMES, "panda_finger_joint1", "fr3_joint1", "", "panda_joint8"]), st.text(max_size=12)
)


def stamps() -> st.SearchStrategy[Time]:
    return st.builds(Time, sec=INT32, nanosec=st.integers(0, 999_999_999))


def durations() -> st.SearchStrategy[Duration]:
    plausible = st.builds(Duration, sec=st.integers(0, 5), nanosec=st.integers(0, 999_999_999))
    return plausible | st.builds(Duration, sec=INT32, nanosec=UINT32)


def float_lists(min_size: int = 0, max_size: int = 16, low: float = -2.0, high: float = 2.0):
    return st.lists(floats(low, high), min_size=min_size, max_size=max_size)


# -- joint states ------------------------------------------------------------------------------------------------
@st.composite
def joint_names(draw, valid: tuple[str, ...] = JOINT_NAMES) -> list[str]:
    """The joints in some order (possibly extra, missing or duplicated ones), or any names."""
    names = list(draw(st.permutations(valid)))
    choice = draw(st.sampled_from([0, 0, 0, 1, 2, 3, 4]))  # mostly the right joints
    if choice == 1:  # a duplicate
        names.insert(draw(st.integers(0, len(names))), draw(st.sampled_from(names)))
    elif choice == 2:  # one missing
        names.pop(draw(st.integers(0, len(names) - 1)))
    elif choice == 3:  # extra joints
        names += draw(st.lists(NAMES, max_size=3))
    elif choice == 4:
        names = draw(st.lists(NAMES, max_size=12))
    return names


@st.composite
def joint_states(draw, valid: tuple[str, ...] = JOINT_NAMES) -> JointState:
    names = draw(joint_names(valid))
    n = len(names)
    plausible = [float(v) for v in Q_READY] + [0.0] * max(0, n - 7)
    position = draw(
        st.one_of(
            st.just(plausible[:n]),
            st.lists(floats(-3.0, 3.0), min_size=n, max_size=n),
            float_lists(max_size=14, low=-3.0, high=3.0),
        )
    )
    velocity = draw(st.one_of(st.just([]), st.lists(floats(), min_size=n, max_size=n), float_lists(max_size=14)))
    effort = draw(st.one_of(st.just([]), float_lists(max_size=14)))
    return JointState(name=names, position=position, velocity=velocity, effort=effort)


# -- poses and plan requests -------------------------------------------------------------------------------------
@st.composite
def quaternions(draw) -> list[float]:
    kind = draw(st.integers(0, 3))
    if kind == 0:
        return [0.0, 0.0, 0.0, 1.0]
    if kind == 1:
        return [1.0, 0.0, 0.0, 0.0]  # the Panda's hand pointing down
    return [draw(floats(-1.0, 1.0)) for _ in range(4)]


@st.composite
def pose_stampeds(draw) -> PoseStamped:
    msg = PoseStamped()
    msg.header.frame_id = draw(FRAMES)
    msg.header.stamp = draw(stamps())
    p = msg.pose.position
    p.x, p.y, p.z = draw(floats(0.2, 0.7)), draw(floats(-0.5, 0.5)), draw(floats(-0.1, 0.9))
    o = msg.pose.orientation
    o.x, o.y, o.z, o.w = draw(quaternions())
    return msg


@st.composite
def plan_requests(draw) -> GetPlan.Request:
    tolerance = draw(st.one_of(st.just(0.0), st.floats(0.001, 0.1), ANY_FLOAT))
    return GetPlan.Request(start=draw(pose_stampeds()), goal=draw(pose_stampeds()), tolerance=tolerance)


# -- point clouds ------------------------------------------------------------------------------------------------
@st.composite
def point_arrays(draw, columns: int = 3, large: tuple[int, ...] = (1000, 20_000, 300_000)) -> np.ndarray:
    """(N, columns) float32: N from 0 to max(large) (rarely large), points in the workspace, some NaN/inf or huge."""
    n = draw(st.one_of(st.integers(0, 64), st.integers(0, 64), st.sampled_from(large)))
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    pts = rng.uniform([0.0, -0.6, -0.05], [1.0, 0.6, 0.95], (n, 3)).astype(np.float32)
    if columns != 3:
        pts = np.concatenate([pts, rng.normal(size=(n, columns - 3)).astype(np.float32)], axis=1)
    if n and draw(st.booleans()):
        k = draw(st.integers(1, n))
        rows, cols = rng.integers(0, n, k), rng.integers(0, columns, k)
        pts[rows, cols] = draw(st.sampled_from([np.nan, np.inf, -np.inf, 3e38, -3e38, 1e-40]))
    return pts


def _mutate_cloud(draw, msg: PointCloud2) -> PointCloud2:
    """One to three layout faults: truncated or extra data, wrong sizes, steps, fields, types, endianness."""
    for _ in range(draw(st.integers(1, 3))):
        kind = draw(st.integers(0, 9))
        data = bytes(msg.data)
        if kind == 0:  # truncated data
            msg.data = data[: draw(st.integers(0, max(0, len(data) - 1)))]
        elif kind == 1:  # trailing bytes
            msg.data = data + bytes(draw(st.integers(1, 64)))
        elif kind == 2:
            msg.width = draw(st.one_of(st.integers(0, 2 * max(1, msg.width)), UINT32))
        elif kind == 3:
            msg.height = draw(st.one_of(st.integers(0, 4), UINT32))
        elif kind == 4:
            msg.point_step = draw(st.one_of(st.integers(0, 2 * max(1, msg.point_step)), UINT32))
        elif kind == 5:
            msg.row_step = draw(st.one_of(st.integers(0, 2 * max(1, msg.row_step)), UINT32))
        elif kind == 6:
            msg.is_bigendian = not msg.is_bigendian
        elif kind == 7 and msg.fields:  # one field changed
            fields = list(msg.fields)
            i = draw(st.integers(0, len(fields) - 1))
            f = fields[i]
            fields[i] = PointField(
                name=draw(st.one_of(st.just(f.name), st.sampled_from(["x", "y", "z", "rgb", "f0", "f01", ""]))),
                offset=draw(st.one_of(st.just(f.offset), st.integers(0, 64), UINT32)),
                datatype=draw(st.one_of(st.just(f.datatype), st.integers(0, 255))),
                count=draw(st.one_of(st.just(f.count), st.integers(0, 4), UINT32)),
            )
            msg.fields = fields
        elif kind == 8 and msg.fields:  # a field dropped or duplicated
            fields = list(msg.fields)
            i = draw(st.integers(0, len(fields) - 1))
            msg.fields = fields[:i] + fields[i + 1 :] if draw(st.booleans()) else [*fields, fields[i]]
        elif kind == 9:  # organised: the same bytes as rows
            msg.height = draw(st.integers(1, 4))
            msg.width = msg.width // msg.height
            msg.row_step = msg.width * msg.point_step
    return msg


@st.composite
def point_clouds(draw, frames=FRAMES) -> PointCloud2:
    """A PointCloud2 of x, y, z (sometimes with FLOAT64 fields, padding or extra fields), often with a fault."""
    pts = draw(point_arrays())
    frame, stamp = draw(frames), draw(stamps())
    if draw(st.booleans()):  # extra fields (e.g. rgb) after x, y, z
        msg = xyz_to_cloud(pts, frame, stamp, features=np.zeros((len(pts), 1), np.float32), feature_names=["rgb"])
    else:
        msg = xyz_to_cloud(pts, frame, stamp)
    if draw(st.integers(0, 3)) == 0:
        msg = _as_float64_padded(msg, pts)
    if draw(st.booleans()):
        msg = _mutate_cloud(draw, msg)
    return msg


def _as_float64_padded(msg: PointCloud2, pts: np.ndarray) -> PointCloud2:
    """The same points as FLOAT64 x, y, z with 8 bytes of padding per point and 4 per row."""
    n = len(pts)
    rec = np.zeros(n, dtype=np.dtype({"names": ["x", "y", "z"], "formats": ["<f8"] * 3, "offsets": [0, 8, 16],
                                      "itemsize": 32}))  # fmt: skip
    for i, name in enumerate("xyz"):
        rec[name] = pts[:, i]
    msg.fields = [PointField(name=c, offset=8 * i, datatype=PointField.FLOAT64, count=1) for i, c in enumerate("xyz")]
    msg.point_step, msg.row_step, msg.height, msg.width = 32, 32 * n + 4, 1, n
    msg.data = rec.tobytes() + bytes(4)
    return msg


@st.composite
def embedding_clouds(draw) -> PointCloud2:
    """A scene embedding cloud (centres + f0..fC-1), often with renamed, missing or extra feature fields."""
    channels = draw(st.sampled_from([1, 4, 64, 65]))
    values = draw(point_arrays(columns=3 + channels, large=(1000, 5000)))
    centres, features = values[:, :3], values[:, 3:]
    if np.all(np.isfinite(values)):
        msg = embedding_to_cloud(centres, features, frame_id=draw(FRAMES), stamp=draw(stamps()))
    else:
        msg = xyz_to_cloud(centres, draw(FRAMES), draw(stamps()), features=features)
    if draw(st.booleans()):
        fields = list(msg.fields)
        i = draw(st.integers(0, len(fields) - 1))
        name = draw(st.sampled_from(["f01", "f-1", "f99999999999999999999", "g0", "x", "f", "f1"]))
        fields[i] = PointField(name=name, offset=fields[i].offset, datatype=fields[i].datatype, count=1)
        msg.fields = fields
    if draw(st.booleans()):
        msg = _mutate_cloud(draw, msg)
    return msg


@st.composite
def embedding_variants(draw, base: PointCloud2) -> PointCloud2:
    """A valid scene embedding (`base`) changed in content, not layout: features scaled (to zero, negative, huge
    or NaN), voxels dropped or repeated, centres moved off the grid; sometimes also a layout fault."""
    from msg_adapters import cloud_to_embedding

    centres, features = (a.copy() for a in cloud_to_embedding(base))
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    kind = draw(st.integers(0, 4))
    if kind == 0:
        features *= np.float32(draw(st.sampled_from([0.0, -1.0, 10.0, 1e10, 3e38])))
    elif kind == 1 and len(centres):
        keep = rng.random(len(centres)) < draw(st.floats(0.0, 1.0))
        centres, features = centres[keep], features[keep]
    elif kind == 2 and len(centres):
        rows = rng.integers(0, len(centres), draw(st.integers(1, 2 * len(centres))))
        centres, features = centres[rows], features[rows]
    elif kind == 3:
        centres += rng.normal(0.0, draw(st.sampled_from([1e-4, 0.03, 1.0, 100.0])), centres.shape).astype(np.float32)
    elif kind == 4 and features.size:
        features.flat[rng.integers(0, features.size, 3)] = draw(st.sampled_from([np.nan, np.inf, 3e38]))
    msg = xyz_to_cloud(centres, base.header.frame_id, base.header.stamp, features=features)
    return _mutate_cloud(draw, msg) if draw(st.integers(0, 3)) == 0 else msg


# -- cylinder markers --------------------------------------------------------------------------------------------
_MARKER_TYPES = [Marker.CYLINDER] * 4 + [Marker.CUBE, Marker.SPHERE, Marker.ARROW, Marker.TEXT_VIEW_FACING]


@st.composite
def markers(draw) -> Marker:
    m = Marker()
    m.header.frame_id = draw(st.one_of(st.sampled_from(["world", "", "panda_link0"]), FRAMES))
    m.ns = draw(st.sampled_from(["obstacles", "a", ""]) | st.text(max_size=8))
    m.id = draw(st.integers(0, 5) | INT32)
    m.type = draw(st.sampled_from(_MARKER_TYPES) | INT32)
    m.action = draw(st.sampled_from([Marker.ADD] * 6 + [Marker.DELETE, Marker.DELETEALL]) | INT32)
    h, r = draw(floats(0.01, 0.6)), draw(floats(0.01, 0.2))
    m.scale.x = m.scale.y = 2 * r if draw(st.booleans()) else draw(ANY_FLOAT)
    m.scale.z = h
    m.pose.position.x, m.pose.position.y = draw(floats(-0.8, 0.8)), draw(floats(-0.8, 0.8))
    m.pose.position.z = h / 2 if draw(st.booleans()) else draw(ANY_FLOAT)
    o = m.pose.orientation
    o.x, o.y, o.z, o.w = draw(quaternions())
    if draw(st.integers(0, 4)) == 0:
        m.lifetime = draw(durations())
    return m


def marker_arrays() -> st.SearchStrategy[MarkerArray]:
    return st.builds(MarkerArray, markers=st.lists(markers(), max_size=8))


# -- trajectories ------------------------------------------------------------------------------------------------
@st.composite
def joint_trajectories(draw, valid: tuple[str, ...] = JOINT_NAMES) -> JointTrajectory:
    """Trajectories near the ready pose with increasing times, or any sizes, values and times."""
    names = draw(joint_names(valid))
    n, k = len(names), draw(st.integers(0, 12))
    plausible = draw(st.booleans())  # then within the Panda's limits: 0.3-0.6 s apart, 0.3 rad around the ready pose
    spacing = st.floats(0.3, 0.6) if plausible else st.floats(0.01, 0.5)
    t = np.cumsum(draw(st.lists(spacing, min_size=k, max_size=k))) if k else np.zeros(0)
    derivatives = draw(st.sampled_from(["none", "velocities", "both", "any"]))
    points = []
    for i in range(k):
        if plausible:
            q = [float(v) for v in Q_READY[: min(n, 7)]] + [0.0] * max(0, n - 7)
            positions = [v + draw(st.floats(-0.3, 0.3)) for v in q]
            tfs = Duration(sec=int(t[i]), nanosec=int((t[i] % 1) * 1e9))
        else:
            positions = draw(st.one_of(st.lists(floats(-3.0, 3.0), min_size=n, max_size=n), float_lists(max_size=10)))
            tfs = draw(durations())
        point = JointTrajectoryPoint(positions=positions, time_from_start=tfs)
        values = st.lists(floats(-1.0, 1.0), min_size=n, max_size=n)
        if derivatives in ("velocities", "both") or (derivatives == "any" and draw(st.booleans())):
            point.velocities = draw(values if derivatives != "any" else values | float_lists())
        if derivatives == "both" or (derivatives == "any" and draw(st.booleans())):
            point.accelerations = draw(values if derivatives != "any" else values | float_lists())
        points.append(point)
    msg = JointTrajectory(joint_names=names, points=points)
    msg.header.stamp = draw(st.one_of(st.just(Time()), stamps()))
    return msg


# -- parameter values --------------------------------------------------------------------------------------------
INT64 = st.integers(-(2**63), 2**63 - 1)
PARAMETER_VALUES = st.one_of(
    st.booleans(),
    INT64,
    st.integers(-5, 200),
    ANY_FLOAT,
    st.floats(-1.0, 200.0),
    st.text(max_size=24),
    st.lists(st.booleans(), max_size=4),
    st.lists(INT64, max_size=8),
    st.lists(ANY_FLOAT, max_size=8),
    st.lists(st.text(max_size=12), max_size=4),
)
"""any value a ROS parameter can hold (rclpy infers its type)"""


def _near(value) -> st.SearchStrategy:
    """Values of the type of `value`, near it, at the edges of its range, or far off."""
    if isinstance(value, bool):
        return st.booleans()
    if isinstance(value, int):
        return st.one_of(st.integers(value - 3, value + 3), st.sampled_from([0, -1, 2 * value, 10 * value]), INT64)
    if isinstance(value, float):
        scaled = st.sampled_from([0.0, -1.0, 0.5, 2.0, 10.0, 1e6]).map(lambda k: k * value)
        return st.one_of(scaled, st.floats(-abs(value) - 1.0, 3.0 * abs(value) + 1.0), ANY_FLOAT)
    if isinstance(value, str):
        return st.one_of(st.just(value), st.just(""), st.sampled_from(["learned", "geometric", "none", "exact"]),
                         st.text(max_size=24))  # fmt: skip
    if isinstance(value, list | tuple) and value:
        return st.lists(_near(value[0]), max_size=max(8, 2 * len(value)))
    return PARAMETER_VALUES


@st.composite
def parameters(draw, current: dict) -> Parameter:
    """A Parameter named as one of `current` ({name: value}, or an unknown name) with a value of its type near
    its current one, or of any type."""
    names = sorted(current)
    name = draw(st.sampled_from(names + names[: len(names) // 20] + ["no_such_parameter", "use_sim_time"]))
    value = draw(_near(current[name]) if name in current and draw(st.integers(0, 3)) else PARAMETER_VALUES)
    return Parameter(name, value=value)

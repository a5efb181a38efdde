"""msg_adapters.point_cloud: round trips, arbitrary driver layouts, refusals of malformed clouds."""

from __future__ import annotations

import numpy as np
import pytest
from builtin_interfaces.msg import Time
from sensor_msgs.msg import PointCloud2, PointField

from msg_adapters import AdapterError, cloud_to_fields, cloud_to_xyz, feature_names, xyz_to_cloud

_NP = {PointField.FLOAT32: "<f4", PointField.FLOAT64: "<f8"}


def make_cloud(
    columns: dict[str, np.ndarray],
    datatypes: dict[str, int] | None = None,
    offsets: dict[str, int] | None = None,
    point_step: int | None = None,
    row_padding: int = 0,
    fill: int = 0xAB,
) -> PointCloud2:
    """A cloud of any layout, as a driver might send it. Each column has shape (height, width).

    Padding bytes (inside points and at row ends) are set to `fill`, so reading them would show.
    """
    names = list(columns)
    datatypes = datatypes or {}
    types = {n: datatypes.get(n, PointField.FLOAT32) for n in names}
    sizes = {n: np.dtype(_NP[types[n]]).itemsize for n in names}
    if offsets is None:
        offsets, pos = {}, 0
        for n in names:
            offsets[n] = pos
            pos += sizes[n]
    step = point_step if point_step is not None else max(offsets[n] + sizes[n] for n in names)
    height, width = next(iter(columns.values())).shape
    row_step = width * step + row_padding
    points = np.full((height, width, step), fill, dtype=np.uint8)
    for n in names:
        values = np.ascontiguousarray(columns[n].astype(_NP[types[n]]))[..., None]
        points[:, :, offsets[n] : offsets[n] + sizes[n]] = values.view(np.uint8)
    buf = np.full((height, row_step), fill, dtype=np.uint8)
    buf[:, : width * step] = points.reshape(height, width * step)
    msg = PointCloud2()
    msg.height, msg.width = height, width
    msg.fields = [PointField(name=n, offset=offsets[n], datatype=types[n], count=1) for n in names]
    msg.point_step, msg.row_step = step, row_step
    msg.data = buf.tobytes()
    return msg


def test_round_trip_xyz(rng):
    pts = rng.normal(size=(50, 3)).astype(np.float32)
    msg = xyz_to_cloud(pts, frame_id="camera", stamp=Time(sec=1, nanosec=2))
    assert (msg.height, msg.width, msg.point_step, msg.row_step) == (1, 50, 12, 600)
    assert [f.name for f in msg.fields] == ["x", "y", "z"]
    assert all(f.datatype == PointField.FLOAT32 and f.count == 1 for f in msg.fields)
    assert msg.header.frame_id == "camera" and msg.header.stamp == Time(sec=1, nanosec=2)
    assert msg.is_dense and not msg.is_bigendian
    out = cloud_to_xyz(msg)
    assert out.dtype == np.float32
    np.testing.assert_array_equal(out, pts)
    assert feature_names(msg) == []


def test_round_trip_random_with_features(rng):
    """120 random clouds: sizes 0..300, 0..8 features, default or custom names, some NaN points."""
    for case in range(120):
        n, f = int(rng.integers(0, 300)), int(rng.integers(0, 9))
        pts = rng.uniform(-2, 2, size=(n, 3))
        feats = rng.normal(size=(n, f)) if f else None
        names = None if (f == 0 or case % 2) else [f"feat_{i}" for i in range(f)]
        n_bad = min(n, int(rng.integers(0, 4)))
        bad_rows = rng.choice(n, size=n_bad, replace=False) if n_bad else np.array([], dtype=int)
        if n_bad:
            pts[bad_rows, rng.integers(0, 3, size=n_bad)] = rng.choice([np.nan, np.inf, -np.inf], size=n_bad)
        msg = xyz_to_cloud(pts, features=feats, feature_names=names)
        assert msg.is_dense == (n_bad == 0)
        expected_names = ([f"f{i}" for i in range(f)] if names is None else names) if f else []
        assert feature_names(msg) == expected_names
        keep = np.ones(n, dtype=bool)
        keep[bad_rows] = False
        np.testing.assert_array_equal(cloud_to_xyz(msg), pts[keep].astype(np.float32))
        if f:
            both = cloud_to_fields(msg, ["x", "y", "z", *expected_names])
            want = np.concatenate([pts, feats], axis=1)[keep].astype(np.float32)
            np.testing.assert_array_equal(both, want)
            assert both.shape == (keep.sum(), 3 + f)


def test_random_driver_layouts(rng):
    """150 random layouts: shuffled field order, point and row padding, organised, float64 fields, NaNs."""
    for _ in range(150):
        height, width = int(rng.integers(1, 5)), int(rng.integers(0, 40))
        names = ["x", "y", "z", "intensity", "f0"][: int(rng.integers(3, 6))]
        order = list(rng.permutation(names))
        types = {n: PointField.FLOAT64 if rng.random() < 0.3 else PointField.FLOAT32 for n in names}
        offsets, pos = {}, int(rng.integers(0, 5))
        for n in order:
            offsets[n] = pos
            pos += np.dtype(_NP[types[n]]).itemsize + int(rng.integers(0, 5))
        cols = {n: rng.uniform(-5, 5, size=(height, width)) for n in order}
        if width:
            for _ in range(int(rng.integers(0, 3))):
                cols[order[rng.integers(len(order))]][rng.integers(height), rng.integers(width)] = np.nan
        msg = make_cloud(
            cols,
            datatypes=types,
            offsets=offsets,
            point_step=pos + int(rng.integers(0, 8)),
            row_padding=int(rng.integers(0, 16)),
        )
        msg.is_dense = bool(rng.random() < 0.5)  # drivers get this wrong; the reader must not trust it
        want_names = list(rng.permutation(names))
        want = np.stack([cols[n].reshape(-1) for n in want_names], axis=1).astype(np.float32)
        want = want[np.all(np.isfinite(want), axis=1)]
        np.testing.assert_array_equal(cloud_to_fields(msg, want_names), want)
        xyz = np.stack([cols[n].reshape(-1) for n in "xyz"], axis=1).astype(np.float32)
        np.testing.assert_array_equal(cloud_to_xyz(msg), xyz[np.all(np.isfinite(xyz), axis=1)])


def test_organised_cloud_order_and_nan_dropping():
    x = np.array([[0.0, 1.0, 2.0], [3.0, np.nan, 5.0]])
    msg = make_cloud({"x": x, "y": x + 10, "z": x + 20}, point_step=16, row_padding=8)
    out = cloud_to_xyz(msg)
    np.testing.assert_array_equal(out[:, 0], [0, 1, 2, 3, 5])
    np.testing.assert_array_equal(out[:, 2], [20, 21, 22, 23, 25])


def test_requested_field_order_and_repeats():
    x = np.arange(4.0).reshape(1, 4)
    msg = make_cloud({"z": x + 2, "x": x, "y": x + 1})
    np.testing.assert_array_equal(cloud_to_fields(msg, ["y", "y", "x"]), np.stack([x[0] + 1, x[0] + 1, x[0]], axis=1))


def test_non_finite_only_in_unrequested_field_keeps_point():
    x = np.zeros((1, 3))
    msg = make_cloud({"x": x, "y": x, "z": x, "f0": np.full((1, 3), np.nan)})
    assert cloud_to_xyz(msg).shape == (3, 3)
    assert cloud_to_fields(msg, ["f0"]).shape == (0, 1)


def test_empty_cloud():
    assert cloud_to_xyz(PointCloud2(fields=xyz_to_cloud(np.zeros((0, 3))).fields)).shape == (0, 3)
    msg = xyz_to_cloud(np.zeros((0, 3)), features=np.zeros((0, 4)))
    assert cloud_to_fields(msg, ["f3", "x"]).shape == (0, 2)


def _xyz_cloud(n: int = 4) -> PointCloud2:
    return xyz_to_cloud(np.arange(3 * n, dtype=float).reshape(n, 3))


def test_refuses_big_endian():
    msg = _xyz_cloud()
    msg.is_bigendian = True
    with pytest.raises(AdapterError, match="big-endian"):
        cloud_to_xyz(msg)


def test_refuses_missing_fields():
    msg = make_cloud({"x": np.zeros((1, 2)), "y": np.zeros((1, 2))})
    with pytest.raises(AdapterError, match=r"lacks fields \['z'\]"):
        cloud_to_xyz(msg)
    with pytest.raises(AdapterError, match=r"lacks fields \['f0'\]"):
        cloud_to_fields(_xyz_cloud(), ["x", "f0"])


@pytest.mark.parametrize(
    ("datatype", "label"),
    [
        (PointField.INT8, "INT8"),
        (PointField.UINT8, "UINT8"),
        (PointField.INT16, "INT16"),
        (PointField.UINT16, "UINT16"),
        (PointField.INT32, "INT32"),
        (PointField.UINT32, "UINT32"),
        (0, "unknown type 0"),
        (42, "unknown type 42"),
    ],
)
def test_refuses_non_float_fields(datatype, label):
    msg = _xyz_cloud()
    msg.fields[1].datatype = datatype
    with pytest.raises(AdapterError, match=f"field 'y' is {label}"):
        cloud_to_xyz(msg)


def test_float64_fields_are_converted():
    x = np.array([[0.1, 1e-3, 123.456]])
    msg = make_cloud({"x": x, "y": x, "z": x}, datatypes={"x": PointField.FLOAT64})
    out = cloud_to_xyz(msg)
    assert out.dtype == np.float32
    np.testing.assert_array_equal(out[:, 0], x[0].astype(np.float32))


@pytest.mark.parametrize("count", [0, 3])
def test_refuses_count_other_than_one(count):
    msg = _xyz_cloud()
    msg.fields[2].count = count
    with pytest.raises(AdapterError, match=f"field 'z' has count {count}"):
        cloud_to_xyz(msg)


def test_refuses_truncated_data():
    msg = _xyz_cloud(4)
    msg.data = bytes(msg.data)[:-1]
    with pytest.raises(AdapterError, match="truncated: 47 bytes < row_step 48"):
        cloud_to_xyz(msg)


def test_refuses_truncated_organised_data():
    msg = make_cloud({n: np.zeros((3, 2)) for n in "xyz"}, row_padding=4)
    msg.data = bytes(msg.data)[: msg.row_step * 2]
    with pytest.raises(AdapterError, match=r"row_step 28 \* height 3"):
        cloud_to_xyz(msg)


def test_refuses_point_step_smaller_than_fields():
    msg = _xyz_cloud()
    msg.point_step = 10
    with pytest.raises(AdapterError, match="field 'z' .* extends past point_step 10"):
        cloud_to_xyz(msg)


def test_refuses_row_step_smaller_than_row():
    msg = _xyz_cloud(4)
    msg.row_step = 40
    with pytest.raises(AdapterError, match="row_step 40 < width 4"):
        cloud_to_xyz(msg)


def test_refuses_no_names():
    with pytest.raises(AdapterError, match="no field names"):
        cloud_to_fields(_xyz_cloud(), [])


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"points": np.zeros((4, 2))}, r"points: expected shape \(N, 3\)"),
        ({"points": np.zeros(3)}, r"points: expected shape \(N, 3\)"),
        ({"points": np.zeros((4, 3)), "features": np.zeros((3, 2))}, r"features: expected shape \(4, F\)"),
        ({"points": np.zeros((4, 3)), "features": np.zeros((4, 2)), "feature_names": ["a"]}, "1 feature names"),
        ({"points": np.zeros((4, 3)), "features": np.zeros((4, 2)), "feature_names": ["a", "a"]}, "unique"),
        ({"points": np.zeros((4, 3)), "features": np.zeros((4, 1)), "feature_names": ["x"]}, "unique"),
        ({"points": np.zeros((4, 3)), "features": np.zeros((4, 1)), "feature_names": [""]}, "non-empty"),
        ({"points": np.zeros((4, 3)), "feature_names": ["a"]}, "without features"),
    ],
)
def test_xyz_to_cloud_refuses(kwargs, match):
    with pytest.raises(AdapterError, match=match):
        xyz_to_cloud(**kwargs)

"""sensor_msgs/PointCloud2 <-> numpy arrays of float32 fields (x, y, z [m] and extra features).

Reading handles any layout a driver may produce for float fields: padding inside a point
(point_step larger than the fields), padding at the end of each row (row_step > width * point_step),
organised clouds (height > 1) and non-dense clouds (NaN/inf points are dropped).
Written clouds are unorganised (height 1), little-endian, packed float32.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from builtin_interfaces.msg import Time
from sensor_msgs.msg import PointCloud2, PointField

from msg_adapters._common import stamp_or_zero
from msg_adapters.errors import AdapterError

XYZ = ("x", "y", "z")

# Float field types we read; FLOAT64 is converted to float32. Integer types are refused.
_FLOAT_TYPES: dict[int, np.dtype] = {PointField.FLOAT32: np.dtype("<f4"), PointField.FLOAT64: np.dtype("<f8")}
_TYPE_NAMES = {
    PointField.INT8: "INT8",
    PointField.UINT8: "UINT8",
    PointField.INT16: "INT16",
    PointField.UINT16: "UINT16",
    PointField.INT32: "INT32",
    PointField.UINT32: "UINT32",
    PointField.FLOAT32: "FLOAT32",
    PointField.FLOAT64: "FLOAT64",
}


def feature_names(msg: PointCloud2) -> list[str]:
    """Names of the fields other than x, y, z, in the message's field order (e.g. f0..fN-1)."""
    return [f.name for f in msg.fields if f.name not in XYZ]


def cloud_to_xyz(msg: PointCloud2) -> np.ndarray:
    """Points of a cloud: shape (N, 3) float32 [m] in msg.header.frame_id; NaN/inf points dropped."""
    return cloud_to_fields(msg, XYZ)


def cloud_to_fields(msg: PointCloud2, names: Sequence[str]) -> np.ndarray:
    """The named float fields of every point: shape (N, len(names)) float32.

    Points are in row-major order (row by row for organised clouds); rows holding a NaN/inf in any
    requested field are dropped.

    Raises:
        AdapterError: big-endian data, a missing field, a field that is not FLOAT32/FLOAT64 or has
            count != 1, a field extending past point_step, row_step < width * point_step,
            or data shorter than row_step * height. A cloud without points only needs valid field types.
    """
    names = list(names)
    if not names:
        raise AdapterError("no field names requested")
    if msg.is_bigendian:
        raise AdapterError("PointCloud2 is big-endian; only little-endian clouds are supported")
    by_name = {f.name: f for f in msg.fields}
    missing = [n for n in names if n not in by_name]
    if missing:
        raise AdapterError(f"PointCloud2 lacks fields {missing} (has {[f.name for f in msg.fields]})")

    height, width, point_step, row_step = int(msg.height), int(msg.width), int(msg.point_step), int(msg.row_step)
    unique = list(dict.fromkeys(names))
    formats, offsets = [], []
    for name in unique:
        field = by_name[name]
        if field.datatype not in _FLOAT_TYPES:
            kind = _TYPE_NAMES.get(field.datatype, f"unknown type {field.datatype}")
            raise AdapterError(f"PointCloud2 field {name!r} is {kind}; only FLOAT32 (or FLOAT64) fields are read")
        if field.count != 1:
            raise AdapterError(f"PointCloud2 field {name!r} has count {field.count}; only count 1 is supported")
        dtype = _FLOAT_TYPES[field.datatype]
        if height * width and field.offset + dtype.itemsize > point_step:
            raise AdapterError(
                f"PointCloud2 field {name!r} (offset {field.offset}, {dtype.itemsize} bytes) "
                f"extends past point_step {point_step}"
            )
        formats.append(dtype)
        offsets.append(int(field.offset))

    if height * width == 0:
        return np.empty((0, len(names)), dtype=np.float32)
    if row_step < width * point_step:
        raise AdapterError(f"PointCloud2 row_step {row_step} < width {width} * point_step {point_step}")
    if len(msg.data) < row_step * height:
        raise AdapterError(
            f"PointCloud2 data is truncated: {len(msg.data)} bytes < row_step {row_step} * height {height}"
        )

    raw = np.frombuffer(msg.data, dtype=np.uint8, count=row_step * height).reshape(height, row_step)
    packed = np.ascontiguousarray(raw[:, : width * point_step])  # drops row padding
    record = np.dtype({"names": unique, "formats": formats, "offsets": offsets, "itemsize": point_step})
    points = packed.view(record).reshape(height * width)
    columns = {name: points[name].astype(np.float32) for name in unique}
    out = np.stack([columns[n] for n in names], axis=1)
    return out[np.all(np.isfinite(out), axis=1)]


def xyz_to_cloud(
    points: np.ndarray,
    frame_id: str = "world",
    stamp: Time | None = None,
    features: np.ndarray | None = None,
    feature_names: Sequence[str] | None = None,
) -> PointCloud2:
    """An unorganised cloud (height 1) with float32 fields x, y, z [m], then one field per feature column.

    Args:
        points: shape (N, 3) [m] in frame_id; NaN/inf points are kept (is_dense is then False).
        frame_id, stamp: header (stamp a builtin_interfaces/Time, zero when None).
        features: optional shape (N, F) extra values per point (e.g. voxel features), stored as float32.
        feature_names: F unique names other than x, y, z; default f0..fF-1.

    Raises:
        AdapterError: wrong shapes, or bad/duplicate feature names.
    """
    pts = np.asarray(points)
    if pts.ndim != 2 or pts.shape[1] != 3:
        raise AdapterError(f"points: expected shape (N, 3), got {pts.shape}")
    columns = [pts.astype(np.float32)]
    names = list(XYZ)
    if features is not None:
        feats = np.asarray(features)
        if feats.ndim != 2 or feats.shape[0] != pts.shape[0]:
            raise AdapterError(f"features: expected shape ({pts.shape[0]}, F), got {feats.shape}")
        extra = [f"f{i}" for i in range(feats.shape[1])] if feature_names is None else list(feature_names)
        if len(extra) != feats.shape[1]:
            raise AdapterError(f"{len(extra)} feature names for {feats.shape[1]} feature columns")
        columns.append(feats.astype(np.float32))
        names += extra
    elif feature_names is not None and len(feature_names) > 0:
        raise AdapterError("feature_names given without features")
    if len(set(names)) != len(names) or not all(isinstance(n, str) and n for n in names):
        raise AdapterError(f"field names must be unique non-empty strings, got {names}")

    values = np.concatenate(columns, axis=1).astype("<f4", copy=False)
    n, k = values.shape
    msg = PointCloud2()
    msg.header.frame_id = frame_id
    msg.header.stamp = stamp_or_zero(stamp)
    msg.height = 1
    msg.width = n
    msg.fields = [
        PointField(name=name, offset=4 * i, datatype=PointField.FLOAT32, count=1) for i, name in enumerate(names)
    ]
    msg.is_bigendian = False
    msg.point_step = 4 * k
    msg.row_step = 4 * k * n
    msg.data = np.ascontiguousarray(values).tobytes()
    msg.is_dense = bool(np.all(np.isfinite(values)))
    return msg

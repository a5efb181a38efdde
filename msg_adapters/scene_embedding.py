"""A scene embedding as sensor_msgs/PointCloud2: voxel centres (x, y, z) with float32 feature fields f0..fC-1.

The scene_encoder node publishes with embedding_to_cloud; the planner reads with cloud_to_embedding and
rebuilds the grid (e.g. CollisionPredictor.embedding_from_points). Only numpy here, no torch.
"""

from __future__ import annotations

import re

import numpy as np
from builtin_interfaces.msg import Time
from sensor_msgs.msg import PointCloud2

from msg_adapters.errors import AdapterError
from msg_adapters.point_cloud import XYZ, cloud_to_fields, feature_names, xyz_to_cloud

_FEATURE = re.compile(r"f(0|[1-9][0-9]*)")


def embedding_to_cloud(
    centres: np.ndarray, features: np.ndarray, frame_id: str = "world", stamp: Time | None = None
) -> PointCloud2:
    """Voxel centres (V, 3) [m] and their features (V, C) -> an unorganised cloud with fields x, y, z, f0..fC-1.

    Raises:
        AdapterError: wrong shapes, no feature channel, or non-finite values.
    """
    centres, features = np.asarray(centres), np.asarray(features)
    if features.ndim != 2 or features.shape[1] < 1:
        raise AdapterError(f"features: expected shape (V, C) with C >= 1, got {features.shape}")
    if not (np.all(np.isfinite(centres)) and np.all(np.isfinite(features))):
        raise AdapterError("scene embedding has non-finite centres or features")
    return xyz_to_cloud(centres, frame_id=frame_id, stamp=stamp, features=features)


def cloud_to_embedding(msg: PointCloud2) -> tuple[np.ndarray, np.ndarray]:
    """Voxel centres (V, 3) float32 [m] in msg.header.frame_id and features (V, C) float32 (columns f0..fC-1).

    The feature fields may come in any order in the message but must be exactly f0..fC-1 (C >= 1).

    Raises:
        AdapterError: other or missing feature fields, a non-finite value (a voxel would be lost), or any
            layout problem cloud_to_fields refuses.
    """
    extra = feature_names(msg)
    bad = [n for n in extra if not _FEATURE.fullmatch(n)]
    if bad:
        raise AdapterError(f"scene embedding has fields {bad} other than x, y, z, f0..fC-1")
    index = sorted(int(n[1:]) for n in extra)
    if not index or index != list(range(len(index))):
        raise AdapterError(f"scene embedding needs feature fields f0..fC-1 (C >= 1), got {extra}")
    names = [f"f{i}" for i in index]
    values = cloud_to_fields(msg, [*XYZ, *names])
    if len(values) != int(msg.width) * int(msg.height):
        raise AdapterError(f"scene embedding has {int(msg.width) * int(msg.height) - len(values)} non-finite voxels")
    return np.ascontiguousarray(values[:, :3]), np.ascontiguousarray(values[:, 3:])

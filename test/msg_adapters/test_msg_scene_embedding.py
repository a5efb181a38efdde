"""Scene embeddings as PointCloud2: voxel centres + f0..fC-1, round trip and refusals."""

from __future__ import annotations

import numpy as np
import pytest
import torch
from builtin_interfaces.msg import Time
from sensor_msgs.msg import PointField

from latent_planner_ros.models.scene_encoder import SceneEmbedding, SceneEncoderConfig
from msg_adapters import AdapterError, cloud_to_embedding, embedding_to_cloud, xyz_to_cloud

SMALL = SceneEncoderConfig(voxel_size=0.2, bounds_max=(1.0, 0.6, 0.75), conv_channels=(8, 5))


def _embedding(rng) -> SceneEmbedding:
    nx, ny, nz = SMALL.grid_shape
    return SceneEmbedding(torch.as_tensor(rng.normal(size=(5, nx, ny, nz)), dtype=torch.float32), SMALL)


def test_round_trip_rebuilds_the_embedding(rng):
    emb = _embedding(rng)
    centres, feats = emb.to_points()
    msg = embedding_to_cloud(centres, feats, stamp=Time(sec=4, nanosec=5))
    assert msg.header.frame_id == "world" and (msg.header.stamp.sec, msg.header.stamp.nanosec) == (4, 5)
    assert [f.name for f in msg.fields] == ["x", "y", "z", "f0", "f1", "f2", "f3", "f4"]
    c2, f2 = cloud_to_embedding(msg)
    np.testing.assert_array_equal(c2, centres)
    np.testing.assert_array_equal(f2, feats)
    torch.testing.assert_close(SceneEmbedding.from_points(c2, f2, SMALL).features, emb.features)


def test_feature_fields_in_any_order(rng):
    centres, feats = _embedding(rng).to_points()
    msg = embedding_to_cloud(centres, feats)
    msg.fields = [msg.fields[i] for i in (5, 0, 7, 1, 3, 2, 4, 6)]  # same offsets, shuffled list
    c2, f2 = cloud_to_embedding(msg)
    np.testing.assert_array_equal(c2, centres)
    np.testing.assert_array_equal(f2, feats)


def test_refusals(rng):
    centres, feats = _embedding(rng).to_points()
    with pytest.raises(AdapterError, match="C >= 1"):
        embedding_to_cloud(centres, feats[:, :0])
    bad = feats.copy()
    bad[3, 1] = np.nan
    with pytest.raises(AdapterError, match="non-finite"):
        embedding_to_cloud(centres, bad)
    with pytest.raises(AdapterError, match="f0..fC-1"):
        cloud_to_embedding(xyz_to_cloud(centres))  # no features
    with pytest.raises(AdapterError, match="other than"):
        cloud_to_embedding(xyz_to_cloud(centres, features=feats[:, :2], feature_names=["f0", "rgb"]))
    with pytest.raises(AdapterError, match="f0..fC-1"):
        cloud_to_embedding(xyz_to_cloud(centres, features=feats[:, :2], feature_names=["f0", "f2"]))
    with pytest.raises(AdapterError, match="non-finite voxels"):
        cloud_to_embedding(xyz_to_cloud(centres, features=bad))
    msg = embedding_to_cloud(centres, feats)
    msg.data = msg.data[:-4]
    with pytest.raises(AdapterError, match="truncated"):
        cloud_to_embedding(msg)
    msg = embedding_to_cloud(centres, feats)
    msg.fields[4] = PointField(name="f1", offset=16, datatype=PointField.UINT32, count=1)
    with pytest.raises(AdapterError, match="UINT32"):
        cloud_to_embedding(msg)

"""Dataset shards: reproducible, loadable, resumable."""

import json

import numpy as np
import pytest

from latent_planner_ros.data.dataset import CollisionData, DatasetConfig, generate_dataset
from latent_planner_ros.data.link_geometry import LABEL_LINKS
from latent_planner_ros.data.queries import QuerySamplerConfig

TINY = DatasetConfig(
    scenes_per_shard=2, pool=1500, pool_refresh=50, queries=QuerySamplerConfig(n_uniform=16, n_near=16, candidates=400)
)


def test_shards_are_reproducible_and_load(tmp_path):
    paths = generate_dataset(tmp_path / "a", 3, seed=3, config=TINY, progress=False)
    assert len(paths) == 2 and all(p.exists() for p in paths)
    generate_dataset(tmp_path / "b", 2, seed=3, config=TINY, progress=False)
    a0, b0 = np.load(paths[0]), np.load(tmp_path / "b" / "shard_00000.npz")
    for k in ("q", "scene", "link_labels", "near"):
        np.testing.assert_array_equal(a0[k], b0[k])
    data = CollisionData.load(tmp_path / "a")
    assert len(data.scenes) == 4
    assert data.q.shape == (4 * 32, 7) and data.link_labels.shape == (4 * 32, len(LABEL_LINKS))
    assert data.near.sum() == 4 * 16
    assert set(np.unique(data.scene)) == {0, 1, 2, 3}
    meta = json.loads(paths[0].with_suffix(".json").read_text())
    assert meta["links"] == list(LABEL_LINKS) and len(meta["scenes"]) == 2


def test_existing_shards_are_skipped_and_refresh_picks_up_new_ones(tmp_path):
    generate_dataset(tmp_path, 2, seed=1, config=TINY, progress=False)
    data = CollisionData.load(tmp_path)
    mtime = (tmp_path / "shard_00000.npz").stat().st_mtime_ns
    generate_dataset(tmp_path, 4, seed=1, config=TINY, progress=False)
    assert (tmp_path / "shard_00000.npz").stat().st_mtime_ns == mtime
    assert data.refresh(tmp_path) == 1 and len(data.scenes) == 4
    assert data.refresh(tmp_path) == 0


def test_a_corrupt_shard_is_reported(tmp_path):
    generate_dataset(tmp_path, 2, seed=1, config=TINY, progress=False)
    (tmp_path / "shard_00000.npz").write_bytes(b"not a zip")
    with pytest.raises(ValueError, match="unreadable"):
        CollisionData.load(tmp_path)

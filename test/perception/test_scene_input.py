"""Preparing clouds for the scene encoder (NaN filtering, cropping, bounded size) and the node's status logic."""

from __future__ import annotations

import numpy as np
import pytest

from latent_planner_ros.models.scene_encoder import SceneEncoderConfig
from latent_planner_ros.nodes.scene_encoder_config import SceneEncoderNodeConfig
from latent_planner_ros.params.config import ConfigError, from_params, to_params
from latent_planner_ros.perception.scene_input import (
    ERROR,
    OK,
    WARN,
    SceneInputMonitor,
    crop_to_bounds,
    limit_points,
    prepare_cloud,
)

LOW, HIGH = SceneEncoderConfig().bounds_min, SceneEncoderConfig().bounds_max


def _inside(rng, n):
    return rng.uniform(LOW, HIGH, size=(n, 3)).astype(np.float32)


def test_non_finite_points_are_dropped_as_absent(rng):
    pts = _inside(rng, 100)
    pts[3, 0], pts[10, 2], pts[50, 1] = np.nan, np.inf, -np.inf
    out = prepare_cloud(pts, LOW, HIGH, max_points=1000, voxel=0.02)
    assert (out.points_in, out.points_finite, out.points_inside, out.points_used) == (100, 97, 97, 97)
    np.testing.assert_array_equal(out.points, np.delete(pts, [3, 10, 50], axis=0))
    assert out.points.dtype == np.float32 and out.voxel_m == 0.0
    assert prepare_cloud(pts[:0], LOW, HIGH, 10, 0.02, points_in=40).points_in == 40  # NaNs dropped upstream


def test_crop_is_the_half_open_box_the_encoder_sees():
    pts = np.array(
        [
            [0.0, -0.6, -0.05],  # the lower corner: inside
            [0.999, 0.599, HIGH[2] - 0.001],  # just inside
            [1.0, 0.0, 0.2],  # on the upper x face: outside (the encoder has no voxel there)
            [0.5, 0.0, HIGH[2]],
            [-0.01, 0.0, 0.2],
            [0.5, 0.7, 0.2],
            [0.5, 0.0, -0.2],  # under the table
        ]
    )
    np.testing.assert_array_equal(crop_to_bounds(pts, LOW, HIGH), pts[:2])
    out = prepare_cloud(pts, LOW, HIGH, 10, 0.02)
    assert (out.points_finite, out.points_inside, out.points_used) == (7, 2, 2)


def test_empty_and_all_nan_clouds_give_no_points():
    for pts in (np.zeros((0, 3)), np.full((20, 3), np.nan), np.full((5, 3), 9.0)):
        out = prepare_cloud(pts, LOW, HIGH, 10, 0.02)
        assert out.points.shape == (0, 3) and out.points_used == 0
    with pytest.raises(ValueError, match=r"\(N, 3\)"):
        prepare_cloud(np.zeros((4, 2)), LOW, HIGH, 10, 0.02)


def test_large_clouds_are_voxel_downsampled_below_max_points(rng):
    pts = _inside(rng, 60_000)
    out = prepare_cloud(pts, LOW, HIGH, max_points=5000, voxel=0.02)
    assert 0 < out.points_used <= 5000 and out.points_inside == 60_000
    assert out.voxel_m >= 0.02
    assert np.all(out.points >= np.asarray(LOW, np.float32)) and np.all(out.points < np.asarray(HIGH, np.float32))
    # one point per occupied voxel (the mean of its points): no two output points share a voxel
    keys = np.floor(out.points / out.voxel_m).astype(np.int64)
    assert len(np.unique(keys, axis=0)) == out.points_used
    # a cloud at the limit is untouched
    same = prepare_cloud(pts[:5000], LOW, HIGH, max_points=5000, voxel=0.02)
    np.testing.assert_array_equal(same.points, pts[:5000])
    assert same.voxel_m == 0.0


def test_dense_surface_keeps_its_shape_when_downsampled(rng):
    """A dense table-top patch: downsampling keeps points on the surface and covers the same area."""
    xy = rng.uniform([0.2, -0.3], [0.8, 0.3], size=(40_000, 2))
    pts = np.c_[xy, np.full(len(xy), 0.1)].astype(np.float32)
    out = prepare_cloud(pts, LOW, HIGH, max_points=2000, voxel=0.01)
    assert 1000 < out.points_used <= 2000, "the voxel grows about as much as needed, not far more"
    np.testing.assert_allclose(out.points[:, 2], 0.1, atol=1e-6)
    assert out.points[:, 0].min() < 0.25 and out.points[:, 0].max() > 0.75


def test_limit_points_falls_back_to_evenly_spaced_points(rng):
    pts = _inside(rng, 1000)
    out, voxel = limit_points(pts, 100, 0.0)
    assert voxel == 0.0 and len(out) == 100
    np.testing.assert_array_equal(out[[0, -1]], pts[[0, -1]])
    out, voxel = limit_points(pts, 1, 0.001)  # no voxel size within the tries gets 1000 points down to 1
    assert len(out) == 1 and voxel > 0.001


def test_monitor_states():
    mon = SceneInputMonitor(stale_after_s=1.0)
    r = mon.report(0.0)
    assert (r.level, r.state) == (WARN, "waiting") and "waiting" in r.message

    pts = np.zeros((10, 3), np.float32) + np.float32([0.5, 0.0, 0.2])
    mon.on_encoded(10.0, prepare_cloud(pts, LOW, HIGH, 100, 0.02), encode_ms=3.0)
    r = mon.report(10.5)
    assert (r.level, r.state) == (OK, "ok") and r.values["points_used"] == 10 and r.values["encode_ms"] == 3.0
    assert r.values["cloud_age_s"] == pytest.approx(0.5) and r.values["clouds_encoded"] == 1

    r = mon.report(11.5)
    assert (r.level, r.state) == (WARN, "stale") and "no cloud for 1.5 s" in r.message

    mon.on_refused(12.0, "camera/points refused: PointCloud2 lacks fields ['z']", points_in=7)
    r = mon.report(12.1)
    assert (r.level, r.state) == (ERROR, "refused") and "lacks fields" in r.message
    assert r.values["points_in"] == 7 and r.values["points_used"] == 0  # nothing of the last good cloud
    assert r.values["clouds_refused"] == 1 and "lacks fields" in r.values["last_error"]
    r = mon.report(20.0)
    assert (r.level, r.state) == (ERROR, "stale") and "lacks fields" in r.message  # stale does not hide the error

    mon.on_encoded(21.0, prepare_cloud(np.zeros((0, 3)), LOW, HIGH, 100, 0.02), encode_ms=1.0)
    r = mon.report(21.0)
    assert (r.level, r.state) == (WARN, "empty") and r.message.startswith("empty cloud")
    assert "lacks fields" in r.values["last_error"]  # the last error stays visible after recovery

    mon.on_encoded(22.0, prepare_cloud(pts, LOW, HIGH, 100, 0.02), encode_ms=1.0)
    assert mon.report(22.0).level == OK


def test_node_config_validation_and_yaml():
    import yaml

    from latent_planner_ros.cli import __file__ as cli_file  # the repo's config/ sits beside the package

    config = SceneEncoderNodeConfig()
    assert from_params(SceneEncoderNodeConfig, to_params(config)) == config
    for name, value, match in (
        ("max_points", 0, "max_points"),
        ("max_points", 1.5, "max_points"),
        ("downsample_voxel", -0.01, "downsample_voxel"),
        ("downsample_voxel", float("nan"), "downsample_voxel"),
        ("stale_after_s", 0.0, "stale_after_s"),
        ("status_rate_hz", "fast", "status_rate_hz"),
        ("checkpoint", 3, "checkpoint"),
        ("voxel", 0.1, "unknown parameter"),
    ):
        with pytest.raises(ConfigError, match=match):
            from_params(SceneEncoderNodeConfig, {name: value})
    from pathlib import Path

    yaml_path = Path(cli_file).resolve().parents[1] / "config" / "scene_encoder.yaml"
    params = yaml.safe_load(yaml_path.read_text())["scene_encoder"]["ros__parameters"]
    params.update({f"frames.{k}": v for k, v in params.pop("frames").items()})  # YAML nesting = dotted names
    assert from_params(SceneEncoderNodeConfig, params) == config

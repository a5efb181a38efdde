"""Fusing the clouds of several cameras: newest per topic, stale ones left out, refusals with reasons, origins."""

import numpy as np
import pytest

from latent_planner_ros.perception.cloud_fusion import CloudFusion, CloudRefused, pose_topic_of
from latent_planner_ros.perception.scene_input import limit_points, limit_points_by_origin, origin_groups, prepare_cloud

TOPICS = ("camera/points", "left/points")
EYE_A, EYE_B = np.array([1.6, 0.7, 0.9]), np.array([0.5, -1.2, 1.0])


def _cloud(n: int, seed: int) -> np.ndarray:
    return np.random.default_rng(seed).uniform([0.2, -0.4, 0.0], [0.8, 0.4, 0.4], size=(n, 3)).astype(np.float32)


def test_pose_topic_is_the_sibling_of_the_cloud_topic():
    assert pose_topic_of("camera/points") == "camera/pose"
    assert pose_topic_of("/rig/left/points") == "/rig/left/pose"
    assert pose_topic_of("points") == "pose"


def test_two_topics_fuse_with_one_origin_per_point():
    fusion = CloudFusion(TOPICS, max_age_s=0.5)
    a, b = _cloud(100, 0), _cloud(50, 1)
    fusion.add_pose("camera/points", EYE_A, "world", 10.0)
    fusion.add_cloud("camera/points", a, "world", 10.0)
    fusion.add_cloud("left/points", np.r_[b, [[np.nan, 0, 0]]], "world", 10.02)
    assert fusion.received == {"camera/points": 100, "left/points": 51}
    fused = fusion.fuse()
    assert fused.sources == TOPICS and fused.counts == (100, 50) and fused.stamp_s == pytest.approx(10.02)
    np.testing.assert_array_equal(fused.points, np.r_[a, b])
    assert fused.origins.shape == (150, 3)
    np.testing.assert_array_equal(fused.origins[:100], np.tile(EYE_A, (100, 1)))
    assert np.isnan(fused.origins[100:]).all(), "the left camera's pose is unknown"
    assert fused.origin_summary().startswith("known for 1 of 2 cameras")
    assert "no left/pose received" in fused.origin_summary()
    fusion.add_pose("left/points", EYE_B, "world", 10.0)
    assert fusion.fuse().origin_summary() == "known"


def test_a_newer_cloud_replaces_the_topics_previous_one_and_stale_ones_are_left_out():
    fusion = CloudFusion(TOPICS, max_age_s=0.5)
    fusion.add_cloud("camera/points", _cloud(10, 0), "world", 1.0)
    fusion.add_cloud("left/points", _cloud(20, 1), "world", 1.0)
    fusion.add_cloud("camera/points", _cloud(30, 2), "world", 1.1)
    assert fusion.fuse().counts == (30, 20)
    fusion.add_cloud("camera/points", _cloud(40, 3), "world", 2.0)  # left is now 1.0 s behind
    fused = fusion.fuse()
    assert fused.sources == ("camera/points",) and fused.counts == (40,)
    assert fused.stale == {"left/points": pytest.approx(1.0)}
    assert "left/points (1.00 s behind)" in fused.describe()


def test_refusals_name_the_topic_and_keep_the_previous_cloud():
    fusion = CloudFusion(TOPICS)
    fusion.add_cloud("camera/points", _cloud(10, 0), "world", 1.0)
    with pytest.raises(CloudRefused, match="camera/points refused: frame 'camera_optical' has no transform"):
        fusion.add_cloud("camera/points", _cloud(5, 1), "camera_optical", 1.1)
    with pytest.raises(CloudRefused, match="right/points refused: not a configured cloud topic"):
        fusion.add_cloud("right/points", _cloud(5, 1), "world", 1.1)
    with pytest.raises(CloudRefused, match="left/pose refused"):
        fusion.add_pose("left/points", np.array([np.nan, 0.0, 1.0]), "world", 1.0)
    fused = fusion.fuse()
    assert fused.counts == (10,) and fused.missing == ("left/points",)
    with pytest.raises(ValueError, match="twice"):
        CloudFusion(["a/points", "a/points"])


def test_a_round_completes_when_every_live_camera_has_delivered():
    fusion = CloudFusion(TOPICS, max_age_s=0.5)
    assert not fusion.round_complete()
    fusion.add_cloud("camera/points", _cloud(10, 0), "world", 1.0)
    assert fusion.round_complete(), "a camera that has not delivered yet does not hold the round up"
    fusion.fuse()
    assert not fusion.round_complete()
    fusion.add_cloud("left/points", _cloud(10, 1), "world", 1.0)
    assert not fusion.round_complete(), "camera/points has not delivered since"
    fusion.add_cloud("camera/points", _cloud(10, 2), "world", 1.08)
    assert fusion.round_complete()
    fusion.fuse()
    fusion.add_cloud("camera/points", _cloud(10, 3), "world", 1.16)
    assert not fusion.round_complete()
    fusion.add_cloud("camera/points", _cloud(10, 4), "world", 1.7)  # left went silent: stale, no longer waited for
    assert fusion.round_complete()
    fusion.fuse()
    fusion.add_cloud("camera/points", _cloud(10, 5), "world", 0.05)  # stamps jumped back (a replayed log)
    assert fusion.round_complete(), "left's cloud is 0.95 s away from the newest stamp: stale"


def test_limit_points_by_origin_keeps_each_cameras_origin_and_matches_one_camera():
    a, b = _cloud(4000, 0), _cloud(3000, 1)
    one = np.tile(EYE_A, (len(a), 1))
    pts, org, size = limit_points_by_origin(a, one, 500, 0.02)
    ref, ref_size = limit_points(a, 500, 0.02)
    np.testing.assert_array_equal(pts, ref)
    assert size == ref_size and (org == EYE_A).all()
    both = np.r_[a, b]
    origins = np.r_[one, np.tile(EYE_B, (len(b), 1))]
    pts, org, _ = limit_points_by_origin(both, origins, 800, 0.02)
    assert len(pts) <= 800 and org.shape == pts.shape
    assert {tuple(r) for r in org} == {tuple(EYE_A), tuple(EYE_B)}
    prepared = prepare_cloud(both, (0.0, -0.6, -0.05), (1.0, 0.6, 0.55), 800, 0.02, origins=origins)
    assert prepared.points_used <= 800 and prepared.origins.shape == prepared.points.shape


def test_origin_groups_equal_numpys_unique_inverse_in_any_order_with_nan_rows():
    rng = np.random.default_rng(5)
    cams = np.vstack([rng.uniform(-2, 2, (3, 3)), np.full((1, 3), np.nan)])
    for shuffled in (False, True):
        origins = np.repeat(cams, [400, 2, 700, 50], axis=0)
        if shuffled:
            origins = rng.permutation(origins)
        expected = np.unique(np.nan_to_num(origins, nan=np.inf), axis=0, return_inverse=True)[1].reshape(-1)
        np.testing.assert_array_equal(origin_groups(origins), expected)
    assert origin_groups(np.zeros((0, 3))).shape == (0,)

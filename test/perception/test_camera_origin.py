"""Which camera origin goes with a cloud."""

import numpy as np

from latent_planner_ros.perception.camera_origin import CameraOrigin


def test_no_pose_means_unknown():
    eye, word = CameraOrigin(1.0).for_cloud(5.0)
    assert eye is None and "no camera/pose" in word


def test_a_pose_near_the_cloud_stamp_is_used_and_a_far_one_is_not():
    origin = CameraOrigin(1.0)
    origin.on_pose(np.array([1.6, 0.7, 0.9]), 10.0)
    eye, word = origin.for_cloud(10.5)
    np.testing.assert_allclose(eye, [1.6, 0.7, 0.9])
    assert word == "known"
    eye, word = origin.for_cloud(12.0)
    assert eye is None and "2.00 s" in word


def test_max_age_zero_accepts_any_age():
    origin = CameraOrigin(0.0)
    origin.on_pose(np.array([1.0, 0.0, 1.0]), 0.0)
    eye, word = origin.for_cloud(1000.0)
    assert word == "known" and eye is not None

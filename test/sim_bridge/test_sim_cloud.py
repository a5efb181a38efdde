"""Depth-image processing: unprojection with the sim camera's intrinsics and pose, cropping, voxel downsampling,
noise and dropout."""

from __future__ import annotations

import numpy as np

from latent_planner_ros.data.camera import unproject
from sim_bridge.camera_config import CameraConfig
from sim_bridge.cloud import corrupt_depth, crop, voxel_downsample


def test_unprojection_of_a_plane_facing_the_camera():
    cam = CameraConfig(width=64, height=48, fovy=60.0, position=(0.0, 0.0, 1.0), look_at=(2.0, 0.0, 1.0))
    rays = cam.intrinsics.ray_directions()
    depth = np.full((cam.height, cam.width), 2.0)
    points = unproject(depth, rays, cam.pose())
    np.testing.assert_allclose(points[:, 0], 2.0)  # every pixel on the wall x = 2
    # image top row sees higher z, left column sees larger y (camera looks along +x, up = +z)
    grid = points.reshape(cam.height, cam.width, 3)
    assert grid[0, 0, 2] > grid[-1, 0, 2] and grid[0, 0, 1] > grid[0, -1, 1]
    half_height = np.tan(np.radians(cam.fovy) / 2) * 2.0
    assert abs(grid[:, :, 2].max() - 1.0 - half_height * (1 - 1 / cam.height)) < 1e-9


def test_stride_keeps_every_nth_pixel():
    intrinsics = CameraConfig(width=64, height=48, fovy=50.0).intrinsics
    full = intrinsics.ray_directions()
    assert full.shape == (48, 64, 3)
    np.testing.assert_array_equal(intrinsics.ray_directions(stride=4), full[::4, ::4])
    np.testing.assert_array_equal(intrinsics.ray_directions(stride=5), full[::5, ::5])


def test_crop_and_voxel_downsample(rng):
    points = rng.uniform(-1, 1, size=(5000, 3))
    inside = crop(points, np.array([-0.5, -0.5, -0.5]), np.array([0.5, 0.5, 0.5]))
    assert np.all(np.abs(inside) <= 0.5) and 0 < len(inside) < len(points)
    down = voxel_downsample(inside, 0.25)
    assert len(down) <= 4**3
    keys = np.floor(down / 0.25)
    assert len(np.unique(keys, axis=0)) == len(down)  # one point per voxel, inside its voxel
    np.testing.assert_allclose(voxel_downsample(inside, 0.0), inside)


def test_noise_grows_with_depth_and_dropout_removes_pixels(rng):
    near, far = np.full((100, 100), 0.5), np.full((100, 100), 2.0)
    assert corrupt_depth(near, rng, 0.01, 0.0).std() < corrupt_depth(far, rng, 0.01, 0.0).std() / 10
    dropped = corrupt_depth(far, rng, 0.0, 0.3)
    assert 0.25 < np.isnan(dropped).mean() < 0.35
    np.testing.assert_array_equal(corrupt_depth(far, rng, 0.0, 0.0), far)

"""The virtual depth camera: points on surfaces, occlusion, conventions."""

import numpy as np

from latent_planner_ros.data.camera import CameraConfig, CameraIntrinsics, look_at, sample_camera_pose, unproject
from latent_planner_ros.data.obstacles import Box
from latent_planner_ros.data.render import render_depth, scene_cloud
from latent_planner_ros.data.scene import Scene

NOISELESS = CameraConfig(depth_noise=0.0, depth_noise_quadratic=0.0)
IDENTITY = (0.0, 0.0, 0.0, 1.0)


def _box_distance(points, centre, half):
    """Distance of points to the surface of an axis-aligned box."""
    d = np.abs(points - np.asarray(centre)) - np.asarray(half)
    outside = np.linalg.norm(np.maximum(d, 0.0), axis=1)
    inside = np.minimum(d.max(1), 0.0)
    return np.abs(outside + inside)


def test_points_lie_on_the_table_or_the_object_surface(rng):
    centre, half = (0.5, 0.1, 0.1), (0.08, 0.05, 0.1)
    scene = Scene((Box(centre, IDENTITY, half),))
    for _ in range(3):
        pts = scene_cloud(scene, rng, NOISELESS)
        assert pts.dtype == np.float32 and pts.shape[1] == 3
        on_table = np.abs(pts[:, 2]) < 1e-4
        on_box = _box_distance(pts.astype(float), centre, half) < 1e-4
        assert np.all(on_table | on_box)
        assert on_box.sum() > 50
        lo, hi = np.asarray(NOISELESS.crop_min), np.asarray(NOISELESS.crop_max)
        assert np.all((pts >= lo) & (pts <= hi))


def test_an_occluded_object_gives_fewer_points(rng):
    pose = look_at(np.array([1.6, 0.0, 0.3]), np.array([0.5, 0.0, 0.1]))  # looking along -x
    small = Box((0.3, 0.0, 0.05), IDENTITY, (0.04, 0.04, 0.05))
    wall = Box((0.6, 0.0, 0.15), IDENTITY, (0.02, 0.2, 0.15))  # between camera and small box

    def count(scene):
        pts = scene_cloud(scene, rng, NOISELESS, pose=pose)
        return int((_box_distance(pts.astype(float), small.position, small.half_extents) < 1e-4).sum())

    alone, hidden = count(Scene((small,))), count(Scene((small, wall)))
    assert alone > 30
    assert hidden < 0.2 * alone


def test_depth_is_the_optical_z_coordinate():
    intr = CameraIntrinsics.from_fov(64, 48, 60.0)
    # camera 1 m above the table looking straight down: every pixel sees the table at depth 1
    pose = look_at(np.array([0.5, 0.0, 1.0]), np.array([0.5, 0.0, 0.0]))
    depth = render_depth(Scene(()), pose, intr)
    np.testing.assert_allclose(depth, 1.0, atol=1e-5)


def test_look_at_gives_the_optical_frame():
    # at x = 1 looking back along -x: z forward = -x, x right = +y, y down = -z, a right-handed rotation
    pose = look_at(np.array([1.0, 0.0, 0.5]), np.array([0.0, 0.0, 0.5]))
    np.testing.assert_allclose(pose[:3, :3], [[0.0, 0.0, -1.0], [1.0, 0.0, 0.0], [0.0, -1.0, 0.0]], atol=1e-12)
    np.testing.assert_allclose(pose[:3, 3], [1.0, 0.0, 0.5])
    assert np.linalg.det(pose[:3, :3]) > 0.999
    down = look_at(np.array([0.5, 0.0, 1.0]), np.array([0.5, 0.0, 0.0]))  # straight down: x is world -y
    np.testing.assert_allclose(down[:3, :3], [[0.0, -1.0, 0.0], [-1.0, 0.0, 0.0], [0.0, 0.0, -1.0]], atol=1e-12)


def test_rays_and_unprojection_follow_the_pixel_convention(rng):
    intr = CameraIntrinsics(width=8, height=6, fx=10.0, fy=12.0, cx=3.5, cy=2.5)
    rays = intr.ray_directions()
    assert rays.shape == (6, 8, 3) and np.all(rays[..., 2] == 1.0)
    np.testing.assert_allclose(rays[0, 0], [-0.35, -2.5 / 12.0, 1.0])  # top left: x < 0 (left), y < 0 (up)
    np.testing.assert_allclose(rays[5, 7], [0.35, 2.5 / 12.0, 1.0])
    np.testing.assert_array_equal(intr.ray_directions(stride=3), rays[::3, ::3])
    pose = look_at(np.array([1.2, 0.4, 0.8]), np.array([0.3, -0.1, 0.1]))
    depth = np.full((6, 8), np.nan)
    depth[1, 6], depth[4, 2] = 0.7, 1.3
    depth[0, 0] = np.inf
    points = unproject(depth, rays, pose)
    # each point, seen from the camera, projects back onto its pixel at its depth
    p_cam = (points - pose[:3, 3]) @ pose[:3, :3]
    u, v = intr.fx * p_cam[:, 0] / p_cam[:, 2] + intr.cx, intr.fy * p_cam[:, 1] / p_cam[:, 2] + intr.cy
    np.testing.assert_allclose(np.stack([u, v, p_cam[:, 2]], 1), [[6, 1, 0.7], [2, 4, 1.3]], atol=1e-12)


def test_from_fov_centres_the_principal_point():
    intr = CameraIntrinsics.from_fov(64, 48, 60.0)
    assert (intr.cx, intr.cy) == (31.5, 23.5) and intr.fx == intr.fy
    rays = intr.ray_directions()
    # the outermost pixel centres are half a pixel inside the field of view
    np.testing.assert_allclose(rays[-1, 0, 1], np.tan(np.radians(30.0)) * (1 - 1 / 48), atol=1e-12)


def test_sampled_viewpoints_respect_the_ranges(rng):
    cfg = CameraConfig()
    for _ in range(50):
        pose = sample_camera_pose(rng, cfg)
        eye, z_axis = pose[:3, 3], pose[:3, 2]
        assert cfg.distance[0] - 0.3 < np.linalg.norm(eye - np.asarray(cfg.target)) < cfg.distance[1] + 0.3
        assert z_axis[2] < 0  # looking down at the table
        np.testing.assert_allclose(pose[:3, :3] @ pose[:3, :3].T, np.eye(3), atol=1e-9)


def test_voxel_downsample_keeps_one_mean_point_per_voxel(rng):
    from latent_planner_ros.data.render import voxel_downsample

    pts = rng.random((5000, 3)).astype(np.float32)
    out = voxel_downsample(pts, 0.25)
    assert out.dtype == np.float32 and len(out) == 64
    keys = np.floor(out / 0.25)
    assert len(np.unique(keys, axis=0)) == 64
    np.testing.assert_allclose(np.sort(out[:, 0])[:16].mean(), pts[pts[:, 0] < 0.25, 0].mean(), atol=0.02)

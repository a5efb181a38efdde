"""One camera convention: the sim's cameras are posed and unprojected in the optical frame of data/camera.py, so the
sim's cloud of a scene is data/render.py's cloud of the same scene from the same camera, in `world`."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial import cKDTree
from scipy.spatial.transform import Rotation

from latent_planner_ros.data.camera import unproject
from latent_planner_ros.data.cloud_ops import crop
from latent_planner_ros.data.render import render_depth
from latent_planner_ros.data.scene import Scene
from sim_bridge.camera_config import CameraConfig
from sim_bridge.camera_frame import mujoco_from_optical, optical_from_mujoco
from sim_bridge.obstacles import scenario_obstacles


def test_the_mujoco_frame_flips_y_and_z_of_the_optical_frame():
    optical = CameraConfig(position=(1.0, 0.0, 0.5), look_at=(0.0, 0.0, 0.5)).pose()[:3, :3]
    mujoco = mujoco_from_optical(optical)
    # looking along -x: MuJoCo's camera looks along its -z, its y is image up (world +z), x is shared
    np.testing.assert_allclose(mujoco, [[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]], atol=1e-12)
    assert np.linalg.det(mujoco) > 0.999
    np.testing.assert_array_equal(optical_from_mujoco(mujoco), optical)


def test_the_sim_camera_sits_where_its_config_says(make_sim):
    cam = CameraConfig(position=(0.5, -1.5, 0.6), look_at=(0.5, 0.0, 0.0), fovy=60.0)
    sim = make_sim("empty", camera=cam)
    np.testing.assert_allclose(sim.camera_transform(), cam.pose(), atol=1e-9)
    optical_z = cam.pose()[:3, 2]
    np.testing.assert_allclose(optical_z, [0.0, 1.5, -0.6] / np.linalg.norm([0.0, 1.5, -0.6]), atol=1e-12)
    # the published orientation (camera/pose) is MuJoCo's camera frame: it looks along its -z
    position, quaternion_xyzw = sim.camera_pose()
    np.testing.assert_allclose(position, cam.position, atol=1e-12)
    np.testing.assert_allclose(Rotation.from_quat(quaternion_xyzw).apply([0.0, 0.0, -1.0]), optical_z, atol=1e-9)


def _nearest(points: np.ndarray, to: np.ndarray) -> np.ndarray:
    """Distance [m] (N,) from each of points (N, 3) to its nearest point of `to` (M, 3)."""
    return cKDTree(to).query(points)[0]


@pytest.mark.parametrize(("scenario", "camera"), [("tabletop", "camera"), ("shelf", "shelf_front")])
def test_the_sim_cloud_is_the_rendered_cloud_of_the_same_scene(make_sim, scenario, camera):
    sim = make_sim(scenario, camera=CameraConfig(voxel_size=0.0))  # exact depth, no downsampling
    config = next(c.config for c in sim.rig if c.name == camera)
    cloud = sim.point_cloud(camera).astype(float)
    pose = sim.camera_transform(camera)
    depth = render_depth(Scene(tuple(scenario_obstacles(sim.scenario))), pose, config.intrinsics)
    depth[(depth < config.min_depth) | (depth > config.max_depth)] = np.inf
    rays = config.intrinsics.ray_directions()
    low, high = np.asarray(config.crop_min), np.asarray(config.crop_max)
    rendered = crop(unproject(depth, rays, pose), low, high)
    assert len(cloud) > 20000 and len(rendered) > 20000
    # every sim point lies on the rendered surface (the few off it: edges of the table's box, object outlines)
    off = _nearest(cloud, rendered)
    assert np.percentile(off, 99) < 0.002 and np.mean(off < 0.003) > 0.995, np.percentile(off, [50, 99, 100])
    # and the sim sees most of what was rendered (not: behind the arm, the rendered table beyond the sim's)
    assert np.mean(_nearest(rendered, cloud) < 0.003) > 0.8
    # the check can fail: the same depth image with its rows in the wrong order lands elsewhere
    flipped = crop(unproject(np.flipud(depth), rays, pose), low, high)
    assert np.mean(_nearest(cloud, flipped) < 0.003) < 0.2

"""The depth camera's cloud: geometry on the table, the robot removed (checked with the URDF's meshes), noise."""

from __future__ import annotations

import coal
import numpy as np
import pinocchio as pin
import pytest

from latent_planner_ros.robot.limits import Q_READY
from latent_planner_ros.robot.panda import load_panda
from sim_bridge.camera_config import CameraConfig


def distance_to_robot(points: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Distance [m] (N,) from each point to the robot's collision geometry (pinocchio/coal, from the URDF)."""
    panda = load_panda()
    data, geom_data = panda.model.createData(), pin.GeometryData(panda.collision_model)
    pin.updateGeometryPlacements(panda.model, data, panda.collision_model, geom_data, q)
    out = np.full(len(points), np.inf)
    probe, request, result = coal.Sphere(1e-6), coal.DistanceRequest(), coal.DistanceResult()
    for obj, placement in zip(panda.collision_model.geometryObjects, geom_data.oMg, strict=True):
        obj.geometry.computeLocalAABB()
        centre = placement.act(np.asarray(obj.geometry.aabb_center))
        near = np.linalg.norm(points - centre, axis=1) < obj.geometry.aabb_radius + 0.02
        shape_tf = coal.Transform3s(placement.rotation, placement.translation)
        for i in np.flatnonzero(near):
            result.clear()
            d = coal.distance(obj.geometry, shape_tf, probe, coal.Transform3s(np.eye(3), points[i]), request, result)
            out[i] = min(out[i], d)
    return out


# Arm poses near the table and the objects: ready, reaching forward-down, and turned to the side.
POSES = [Q_READY, Q_READY + [0.0, 0.7, 0.0, 0.5, 0.0, 0.0, 0.0], Q_READY + [0.9, 0.4, 0.0, 0.4, 0.0, 0.2, 0.0]]


def test_empty_table_cloud_lies_on_the_table(make_sim):
    sim = make_sim("empty")
    cloud = sim.point_cloud()
    cam = sim.config.camera
    assert cloud.dtype == np.float32 and cloud.ndim == 2 and cloud.shape[1] == 3
    assert 1000 < len(cloud) < 10000
    assert np.all(np.abs(cloud[:, 2]) < 1e-3), "every point of an empty scene is on the table top (z = 0)"
    assert np.all(cloud >= np.asarray(cam.crop_min) - 1e-6) and np.all(cloud <= np.asarray(cam.crop_max) + 1e-6)


@pytest.mark.parametrize("voxel_size", [0.02, 0.0])
def test_no_point_lies_on_the_robot(make_sim, voxel_size):
    """With removal no point is within 5 mm of the robot; without it many are (so the check can fail).

    Table points (z = 0) around the base are exempt: the base stands on the table, its foot touches them.
    """
    for k, q in enumerate(POSES):
        sim = make_sim("tabletop", seed=k, initial_q=tuple(q), camera=CameraConfig(voxel_size=voxel_size))
        assert not sim.in_collision()
        kept = sim.point_cloud()
        above_table = kept[kept[:, 2] > 0.002]
        assert distance_to_robot(above_table, q).min() > 0.005
        camera = CameraConfig(voxel_size=voxel_size, remove_robot=False)
        everything = make_sim("tabletop", seed=k, initial_q=tuple(q), camera=camera).point_cloud()
        assert (distance_to_robot(everything[everything[:, 2] > 0.002], q) < 0.005).sum() > 20


def test_objects_appear_in_the_cloud(make_sim):
    sim = make_sim("shelf")
    cloud = sim.point_cloud()
    board = cloud[(np.abs(cloud[:, 2] - 0.32) < 0.01) & (np.abs(cloud[:, 0] - 0.55) < 0.1)]
    assert len(board) > 20, "the top of the shelf board (z = 0.32) is seen"


def test_noise_dropout_and_decimation(make_sim):
    exact = make_sim("empty", camera=CameraConfig(voxel_size=0.0)).point_cloud()
    noisy = make_sim("empty", camera=CameraConfig(voxel_size=0.0, depth_noise=0.005)).point_cloud()
    assert np.abs(noisy[:, 2]).std() > 5 * np.abs(exact[:, 2]).std()
    dropped = make_sim("empty", camera=CameraConfig(voxel_size=0.0, dropout=0.5)).point_cloud()
    assert 0.4 < len(dropped) / len(exact) < 0.6
    strided = make_sim("empty", camera=CameraConfig(voxel_size=0.0, stride=2)).point_cloud()
    assert 0.2 < len(strided) / len(exact) < 0.3


def test_noise_is_seeded(make_sim):
    cam = CameraConfig(depth_noise=0.005, dropout=0.1)
    a = make_sim("empty", seed=3, camera=cam).point_cloud()
    b = make_sim("empty", seed=3, camera=cam).point_cloud()
    np.testing.assert_array_equal(a, b)

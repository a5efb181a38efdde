"""The MJCF model against the URDF (pinocchio) reference, the joint limits, and the scene files."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from latent_planner_ros.robot.limits import JOINT_NAMES, Q_MAX, Q_MIN, Q_READY
from latent_planner_ros.robot.panda import load_panda
from sim_bridge.camera_config import CameraConfig
from sim_bridge.mjcf import (
    DEPTH_CAMERA,
    OBJECT_PREFIX,
    TCP_SITE,
    build_scene,
    export_scene,
    load_scene_spec,
)
from sim_bridge.scenario import Scenario, ScenarioError, SceneObject
from sim_bridge.scenario_files import load_scenario

# Frames of the URDF and their MuJoCo counterparts (bodies, and the TCP site).
FRAMES = [f"panda_link{i}" for i in range(1, 8)] + ["panda_hand", "panda_leftfinger", "panda_rightfinger"]


@pytest.fixture(scope="module")
def empty_model() -> mujoco.MjModel:
    return build_scene(Scenario(name="empty")).model


def test_forward_kinematics_matches_the_urdf(empty_model, rng):
    panda = load_panda()
    data = mujoco.MjData(empty_model)
    for q in rng.uniform(Q_MIN, Q_MAX, size=(20, 7)):
        data.qpos[:7] = q
        mujoco.mj_kinematics(empty_model, data)
        ref = panda.fk(q, "panda_hand_tcp")
        np.testing.assert_allclose(data.site(TCP_SITE).xpos, ref.translation, atol=1e-9)
        np.testing.assert_allclose(data.site(TCP_SITE).xmat.reshape(3, 3), ref.rotation, atol=1e-9)
        for frame in FRAMES:
            ref = panda.fk(q, frame)
            np.testing.assert_allclose(data.body(frame).xpos, ref.translation, atol=1e-9, err_msg=frame)


def test_joints_limits_and_actuators(empty_model):
    m = empty_model
    assert m.nq == m.nv == m.nu == 7, "fingers are fixed: the arm's 7 joints only"
    for i, name in enumerate(JOINT_NAMES):
        joint = m.joint(name)
        np.testing.assert_allclose(joint.range, [Q_MIN[i], Q_MAX[i]])
        actuator = m.actuator(name)
        assert actuator.trnid[0] == joint.id
        np.testing.assert_allclose(actuator.ctrlrange, [Q_MIN[i], Q_MAX[i]])
        assert actuator.forcerange[1] == (87.0 if i < 4 else 12.0)
    assert m.opt.integrator == mujoco.mjtIntegrator.mjINT_IMPLICITFAST
    arm_bodies = [m.body(f"panda_link{i}").id for i in range(1, 8)] + [m.body("panda_hand").id]
    assert np.all(m.body_gravcomp[arm_bodies] == 1.0)


def test_ready_keyframe_is_the_srdf_ready_pose(empty_model):
    np.testing.assert_allclose(empty_model.key("ready").qpos, Q_READY)


def test_scene_xml_camera_is_the_config_default():
    spec = load_scene_spec()
    model = spec.compile()
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    cam = CameraConfig()
    camera_id = model.camera(DEPTH_CAMERA).id
    np.testing.assert_allclose(data.cam_xpos[camera_id], cam.position)
    np.testing.assert_allclose(data.cam_xmat[camera_id].reshape(3, 3), cam.rotation(), atol=1e-3)
    assert model.cam_fovy[camera_id] == cam.fovy


def test_camera_config_places_the_camera():
    cam = CameraConfig(position=(0.5, -1.5, 0.6), look_at=(0.5, 0.0, 0.0), fovy=60.0)
    model = build_scene(Scenario(name="empty"), cam).model
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    camera_id = model.camera(DEPTH_CAMERA).id
    np.testing.assert_allclose(data.cam_xpos[camera_id], cam.position)
    optical_axis = -data.cam_xmat[camera_id].reshape(3, 3)[:, 2]
    expected = np.subtract(cam.look_at, cam.position)
    np.testing.assert_allclose(optical_axis, expected / np.linalg.norm(expected), atol=1e-9)
    assert model.cam_fovy[camera_id] == 60.0


@pytest.mark.parametrize("name", ["tabletop", "conveyor", "shelf"])
def test_objects_become_geoms_and_moving_ones_mocap(name):
    scenario = load_scenario(name, seed=0)
    scene = build_scene(scenario)
    m = scene.model
    for obj in scenario.objects:
        body = m.body(OBJECT_PREFIX + obj.name)
        assert (m.body_mocapid[body.id] >= 0) == (obj.motion is not None)
        geom = m.geom(OBJECT_PREFIX + obj.name)
        assert not scene.robot_geoms[geom.id]
        assert (geom.contype[0], geom.conaffinity[0]) == (2, 1)
    assert scene.robot_geoms.sum() == 17  # 9 link meshes + 2 x 4 finger boxes
    assert len(scene.moving) == sum(o.motion is not None for o in scenario.objects)


def test_mujoco_refusal_is_a_scenario_error():
    # Built directly (the YAML validator would refuse the face index first).
    verts = ((0, 0, 0), (0.1, 0, 0), (0, 0.1, 0), (0, 0, 0.1))
    obj = SceneObject(
        name="broken",
        type="mesh",
        position=(0.5, 0, 0.1),
        vertices=verts,
        faces=((0, 2, 1), (0, 1, 3), (0, 3, 2), (1, 2, 99)),
    )
    with pytest.raises(ScenarioError, match="scenario 'bad': MuJoCo cannot build the scene"):
        build_scene(Scenario(name="bad", objects=(obj,)))


def test_export_scene_is_self_contained(tmp_path):
    path = export_scene(tmp_path / "scene.xml", load_scenario("shelf"))
    model = mujoco.MjModel.from_xml_path(str(path))
    assert model.nu == 7 and model.body(OBJECT_PREFIX + "shelf_board").id > 0

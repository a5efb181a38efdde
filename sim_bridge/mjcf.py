"""Build the MuJoCo model of a scenario: ``models/scene.xml`` (which includes ``models/robot.xml``) plus the
scenario's objects and the configured depth camera, through the ``mujoco.MjSpec`` editing API.

The robot's STL meshes come from example-robot-data (``panda_description()``), resolved at load time,
so the package works from a fresh pip install. :func:`export_scene` writes one self-contained XML
(absolute mesh paths) to open in MuJoCo's viewer (``python -m mujoco.viewer --mjcf scene.xml``).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import mujoco
import numpy as np

from latent_planner_ros.robot.description import panda_description
from sim_bridge.camera_config import CameraConfig
from sim_bridge.scenario import Scenario, ScenarioError, SceneObject

MODELS_DIR = Path(__file__).resolve().with_name("models")
SCENE_XML = MODELS_DIR / "scene.xml"
ROBOT_XML = MODELS_DIR / "robot.xml"
ROBOT_ROOT = "panda_link0"
TCP_SITE = "panda_hand_tcp"
DEPTH_CAMERA = "depth_camera"
OVERVIEW_CAMERA = "overview"
OBJECT_PREFIX = "object/"
TARGET_SITE = "target"
TARGET_SITE_GROUP = 5
"""Site group of the target marker: hidden from the depth camera, shown in pictures."""

_GEOM_TYPES = {
    "box": mujoco.mjtGeom.mjGEOM_BOX,
    "sphere": mujoco.mjtGeom.mjGEOM_SPHERE,
    "cylinder": mujoco.mjtGeom.mjGEOM_CYLINDER,
    "capsule": mujoco.mjtGeom.mjGEOM_CAPSULE,
    "mesh": mujoco.mjtGeom.mjGEOM_MESH,
}


@dataclass(frozen=True)
class SceneModel:
    """A compiled scene and the indices the simulator needs.

    Attributes:
        model: the MjModel (robot, table, objects, cameras).
        robot_geoms: (ngeom,) bool, True for the robot's geoms (segmentation and contact classification).
        moving: (object, mocap id) of every object with a motion.
    """

    model: mujoco.MjModel
    robot_geoms: np.ndarray
    moving: tuple[tuple[SceneObject, int], ...]


def wxyz(quaternion_xyzw) -> np.ndarray:
    """(x, y, z, w) -> MuJoCo's (w, x, y, z)."""
    x, y, z, w = quaternion_xyzw
    return np.array([w, x, y, z], dtype=float)


def load_scene_spec() -> mujoco.MjSpec:
    """The base scene (robot, table, lights, cameras) with the robot's mesh files resolved."""
    spec = mujoco.MjSpec.from_file(str(SCENE_XML))
    mesh_dir = panda_description().mesh_dir / "collision"
    for mesh in spec.meshes:
        if mesh.file:  # the include rewrote them relative to models/; they live in example-robot-data
            mesh.file = str(mesh_dir / Path(mesh.file).name)
    return spec


def set_camera(spec: mujoco.MjSpec, name: str, config: CameraConfig) -> None:
    """Place camera `name` at config.position looking at config.look_at with config.fovy (its orientation: the
    optical pose of data/camera.py in MuJoCo's camera frame, config.rotation())."""
    camera = spec.camera(name)
    quat = np.zeros(4)
    mujoco.mju_mat2Quat(quat, config.rotation().flatten())
    camera.pos = np.asarray(config.position, dtype=float)
    camera.alt.type = mujoco.mjtOrientation.mjORIENTATION_QUAT  # replaces the file's xyaxes
    camera.quat = quat
    camera.fovy = float(config.fovy)


def _add_object(spec: mujoco.MjSpec, obj: SceneObject) -> None:
    body = spec.worldbody.add_body(
        name=OBJECT_PREFIX + obj.name,
        pos=np.asarray(obj.position, dtype=float),
        quat=wxyz(obj.quaternion_xyzw),
        mocap=obj.motion is not None,
    )
    geom = body.add_geom(name=OBJECT_PREFIX + obj.name, type=_GEOM_TYPES[obj.type], rgba=np.asarray(obj.rgba))
    geom.contype, geom.conaffinity = 2, 1
    if obj.type == "box":
        geom.size = np.asarray(obj.half_extents, dtype=float)
    elif obj.type == "sphere":
        geom.size = [obj.radius, 0.0, 0.0]
    elif obj.type in ("cylinder", "capsule"):
        geom.size = [obj.radius, obj.half_length, 0.0]
    else:
        spec.add_mesh(
            name=OBJECT_PREFIX + obj.name,
            uservert=np.asarray(obj.vertices, dtype=float).flatten().tolist(),
            userface=np.asarray(obj.faces, dtype=int).flatten().tolist(),
            inertia=mujoco.mjtMeshInertia.mjMESH_INERTIA_CONVEX,
        )
        geom.meshname = OBJECT_PREFIX + obj.name


def _add_target_marker(spec: mujoco.MjSpec, scenario: Scenario) -> None:
    target = scenario.target
    if target is None:
        return
    kwargs = dict(name=TARGET_SITE, type=mujoco.mjtGeom.mjGEOM_SPHERE, size=[0.015, 0, 0], rgba=[0.1, 0.9, 0.2, 0.8])
    if target.object is None:
        spec.worldbody.add_site(pos=np.asarray(target.position, dtype=float), group=TARGET_SITE_GROUP, **kwargs)
        return
    obj = scenario.object(target.object)
    rot = np.zeros(9)
    mujoco.mju_quat2Mat(rot, wxyz(obj.quaternion_xyzw))
    local = rot.reshape(3, 3).T @ np.asarray(target.position, dtype=float)  # world-axes offset -> body frame
    spec.body(OBJECT_PREFIX + obj.name).add_site(pos=local, group=TARGET_SITE_GROUP, **kwargs)


def extra_camera_name(name: str) -> str:
    """The MJCF name of the sim's depth camera `name` other than the first (which is DEPTH_CAMERA)."""
    return f"{DEPTH_CAMERA}_{name}"


def scene_spec(
    scenario: Scenario, camera: CameraConfig | None = None, extra_cameras: Sequence[tuple[str, CameraConfig]] = ()
) -> mujoco.MjSpec:
    """The editable spec of a scenario's scene with the depth camera placed per `camera`, and one more camera
    (MJCF name :func:`extra_camera_name`) per (name, config) of extra_cameras."""
    spec = load_scene_spec()
    spec.modelname = f"panda_{scenario.name}"
    set_camera(spec, DEPTH_CAMERA, camera or CameraConfig())
    for name, config in extra_cameras:
        spec.worldbody.add_camera(name=extra_camera_name(name))
        set_camera(spec, extra_camera_name(name), config)
    for obj in scenario.objects:
        _add_object(spec, obj)
    _add_target_marker(spec, scenario)
    return spec


def build_scene(
    scenario: Scenario, camera: CameraConfig | None = None, extra_cameras: Sequence[tuple[str, CameraConfig]] = ()
) -> SceneModel:
    """Compile a scenario's scene (with the depth camera per `camera` and the extra cameras, see scene_spec).

    Raises:
        ScenarioError: MuJoCo refused the scene (e.g. a degenerate mesh), with its message.
    """
    spec = scene_spec(scenario, camera, extra_cameras)
    try:
        model = spec.compile()
    except ValueError as err:
        raise ScenarioError(f"scenario {scenario.name!r}: MuJoCo cannot build the scene: {err}") from None
    root = model.body(ROBOT_ROOT).id
    robot_geoms = model.body_rootid[model.geom_bodyid] == root
    moving = tuple(
        (obj, int(model.body_mocapid[model.body(OBJECT_PREFIX + obj.name).id]))
        for obj in scenario.objects
        if obj.motion is not None
    )
    return SceneModel(model=model, robot_geoms=robot_geoms, moving=moving)


def export_scene(path: str | Path, scenario: Scenario, camera: CameraConfig | None = None) -> Path:
    """Write the scenario's scene as one self-contained MJCF file (absolute mesh paths); returns the path."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    spec = scene_spec(scenario, camera)
    spec.compile()
    path.write_text(spec.to_xml())
    return path

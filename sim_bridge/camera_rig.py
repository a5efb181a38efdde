"""The sim's depth cameras: which ones, with which settings, and the topics each publishes. No ROS, no MuJoCo.

ROS 2 parameters cannot hold a list of structs, so the ``sim`` node takes the names of its cameras and one
parameter group per name, as nav2 does for its costmap layers::

    sim:
      ros__parameters:
        cameras: [camera, left]      # camera = the camera.* group; left = the left.* group
        camera: {position: [1.6, 0.7, 0.9], look_at: [0.5, 0.0, 0.2]}
        left: {position: [0.4, -1.1, 1.0], look_at: [0.5, 0.0, 0.2]}

A camera other than ``camera`` takes every setting it does not name from the ``camera.*`` group (intrinsics,
noise, crop, ...). A scenario file can bring its own cameras (``cameras:`` in the file, docs/scenarios.md):
with ``scenario_cameras`` they come after the listed ones, their fields over the ``camera.*`` group; a name that
``cameras`` lists keeps its parameters.

Each camera ``<name>`` publishes its cloud on ``<name>/points`` (sensor_msgs/PointCloud2 in ``world``, robot
removed, cropped, downsampled) and its optical centre and orientation on ``<name>/pose``
(geometry_msgs/PoseStamped in ``world``, the cloud's stamp), so ``camera`` keeps the one-camera topics
``camera/points`` and ``camera/pose``. Consumers find a cloud's pose topic beside it
(latent_planner_ros/perception/cloud_fusion.py ``pose_topic_of``).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, replace

from latent_planner_ros.params.config import ConfigError, from_params, to_params
from sim_bridge.camera_config import CameraConfig
from sim_bridge.scenario import Scenario
from sim_bridge.sim_config import SimConfig

DEFAULT_CAMERA = "camera"
"""The camera whose settings are the ``camera.*`` parameters (and the defaults of every other one)."""


@dataclass(frozen=True)
class RigCamera:
    """One depth camera of the sim.

    Attributes:
        name: its name (a ROS name token); topics ``<name>/points`` and ``<name>/pose``.
        config: its intrinsics, pose, rate and cloud processing.
        source: where it was configured: "parameters" or "scenario".
    """

    name: str
    config: CameraConfig
    source: str = "parameters"

    @property
    def points_topic(self) -> str:
        return points_topic(self.name)

    @property
    def pose_topic(self) -> str:
        return pose_topic(self.name)


def points_topic(name: str) -> str:
    """The cloud topic of camera `name`: ``<name>/points``."""
    return f"{name}/points"


def pose_topic(name: str) -> str:
    """The pose topic of camera `name`: ``<name>/pose``."""
    return f"{name}/pose"


def camera_params(name: str, config: CameraConfig) -> dict:
    """Flat ``{<name>.<field>: value}`` parameters of one camera (lists for vectors)."""
    return {f"{name}.{k}": v for k, v in to_params(config).items()}


def camera_from_params(name: str, params: Mapping, base: CameraConfig) -> CameraConfig:
    """The CameraConfig of camera `name` from flat ``<name>.<field>`` parameters over `base`.

    Raises:
        ConfigError: an unknown field or a refused value, named ``<name>.<field>``.
    """
    prefix = f"{name}."
    mine = {k[len(prefix) :]: v for k, v in params.items() if k.startswith(prefix)}
    try:
        return from_params(CameraConfig, mine, base=base)
    except ConfigError as err:
        raise ConfigError(f"{prefix}{err}") from None


def camera_rig(
    config: SimConfig, scenario: Scenario | None = None, named: Mapping[str, CameraConfig] | None = None
) -> tuple[RigCamera, ...]:
    """The cameras of a sim, in publishing order.

    Args:
        config: its settings: ``cameras`` (names), ``camera`` (that camera, and every other one's defaults),
            ``scenario_cameras``.
        scenario: the scene, whose own cameras follow the listed ones when config.scenario_cameras.
        named: settings of listed cameras other than ``camera`` (from their ``<name>.*`` parameters); a listed
            name missing here gets config.camera.
    Raises:
        ConfigError: a scenario camera's fields are refused (already checked when the file was loaded).
    """
    named = named or {}
    rig = [RigCamera(n, config.camera if n == DEFAULT_CAMERA else named.get(n, config.camera)) for n in config.cameras]
    if scenario is not None and config.scenario_cameras:
        for name, fields in scenario.cameras:
            if name not in config.cameras:
                values = {k: tuple(v) if isinstance(v, list) else v for k, v in fields.items()}
                rig.append(RigCamera(name, replace(config.camera, **values), "scenario"))
    return tuple(rig)

"""SimConfig: the simulator's settings. Fields map 1:1 onto the ``sim`` node's ROS parameters and onto
``config/sim.yaml`` (``sim: ros__parameters:``); the camera's are nested under ``camera.``. The cameras other
than ``camera`` that ``cameras`` lists have their own ``<name>.*`` parameters (sim_bridge/camera_rig.py)."""

from __future__ import annotations

from dataclasses import dataclass, field

from latent_planner_ros.params.config import ConfigError, check_int, check_number, check_vector
from latent_planner_ros.robot.limits import Q_READY, within_limits
from sim_bridge.camera_config import CameraConfig
from sim_bridge.scenario import CAMERA_NAME

Vec7 = tuple[float, float, float, float, float, float, float]


@dataclass(frozen=True)
class SimConfig:
    """Simulator settings.

    Attributes:
        scenario: scenario name (a file ``<name>.yaml`` in config/scenarios) or a path to a scenario file.
        scenario_overrides: YAML mapping of generator parameters replacing the file's, e.g. "{speed: 0.1}".
        seed: seed of the scenario generator and the camera noise; -1 draws a fresh one at every reset.
        timestep: [s] physics step (500 Hz by default).
        real_time_factor: simulated seconds per wall-clock second; 0 runs as fast as possible.
        joint_state_rate: [Hz] of ``joint_states``, ``/clock`` and ``sim/in_collision`` (simulated time).
        cloud_rate: [Hz] of ``target_pose`` and of every camera's cloud whose own ``rate`` is 0 (simulated time).
        command_period: [s] a new joint target is approached linearly over this time (the planner's period).
        command_timeout: [s] without a fresh command for this long the arm holds where it is; 0: never.
        velocity_scale: joint speed limit as a fraction of the Panda's V_MAX, in (0, 1].
        initial_q: [rad] (7,) configuration at reset.
        frame_id: frame of the published clouds and poses.
        camera: the depth camera ``camera``, and the defaults of every other camera's settings.
        cameras: names of the depth cameras, in order; each publishes ``<name>/points`` and ``<name>/pose``.
            ``camera`` is set by the ``camera.*`` parameters, any other name by its own ``<name>.*`` ones.
        scenario_cameras: also use the cameras the scenario file defines (after these; a name listed here wins).
    """

    scenario: str = "tabletop"
    scenario_overrides: str = ""
    seed: int = 0
    timestep: float = 0.002
    real_time_factor: float = 1.0
    joint_state_rate: float = 100.0
    cloud_rate: float = 12.5
    command_period: float = 0.1
    command_timeout: float = 1.0
    velocity_scale: float = 1.0
    initial_q: Vec7 = tuple(float(x) for x in Q_READY)
    frame_id: str = "world"
    camera: CameraConfig = field(default_factory=CameraConfig)
    cameras: tuple[str, ...] = ("camera",)
    scenario_cameras: bool = True

    def __post_init__(self) -> None:
        for name in ("scenario", "frame_id"):
            if not isinstance(getattr(self, name), str) or not getattr(self, name):
                raise ConfigError(f"{name}: expected a non-empty string, got {getattr(self, name)!r}")
        if not isinstance(self.scenario_overrides, str):
            raise ConfigError(f"scenario_overrides: expected a YAML mapping string, got {self.scenario_overrides!r}")
        check_int("seed", self.seed, -1, 2**31 - 1)
        check_number("timestep", self.timestep, 1e-4, 0.01)
        check_number("real_time_factor", self.real_time_factor, 0.0, 1000.0)
        check_number("joint_state_rate", self.joint_state_rate, 1.0, 1.0 / self.timestep)
        check_number("cloud_rate", self.cloud_rate, 0.1, self.joint_state_rate)
        check_number("command_period", self.command_period, 0.0, 5.0)
        check_number("command_timeout", self.command_timeout, 0.0, 3600.0)
        check_number("velocity_scale", self.velocity_scale, 0.0, 1.0, open_low=True)
        check_vector("initial_q", self.initial_q, 7)
        if not within_limits(self.initial_q):
            raise ConfigError(f"initial_q: {list(self.initial_q)} is outside the joint limits")
        if not isinstance(self.camera, CameraConfig):
            raise ConfigError("camera: expected a CameraConfig")
        check_camera_names("cameras", self.cameras)
        if not isinstance(self.scenario_cameras, bool):
            raise ConfigError(f"scenario_cameras: expected true or false, got {self.scenario_cameras!r}")


MAX_CAMERAS = 8


def check_camera_names(name: str, names) -> None:
    """ConfigError unless names is a list of 1..MAX_CAMERAS distinct camera names (ROS name tokens) that do not
    shadow another sim parameter."""
    if not isinstance(names, tuple | list) or not 1 <= len(names) <= MAX_CAMERAS:
        raise ConfigError(f"{name}: expected 1 to {MAX_CAMERAS} camera names, got {names!r}")
    reserved = {f for f in SimConfig.__dataclass_fields__ if f != "camera"}
    for n in names:
        if not isinstance(n, str) or not CAMERA_NAME.fullmatch(n) or n in reserved:
            raise ConfigError(f"{name}: {n!r} is not a camera name (a ROS name token, not a sim parameter name)")
    if len(set(names)) != len(names):
        raise ConfigError(f"{name}: {list(names)} lists a camera twice")

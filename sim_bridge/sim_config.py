"""SimConfig: the simulator's settings. Fields map 1:1 onto the ``sim`` node's ROS parameters and onto
``config/sim.yaml`` (``sim: ros__parameters:``); the camera's are nested under ``camera.``."""

from __future__ import annotations

from dataclasses import dataclass, field

from latent_planner_ros.robot.limits import Q_READY, within_limits
from sim_bridge.camera_config import CameraConfig
from sim_bridge.params import ConfigError, check_int, check_number, check_vector

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
        cloud_rate: [Hz] of ``camera/points`` and ``target_pose`` (simulated time).
        command_period: [s] a new joint target is approached linearly over this time (the planner's period).
        command_timeout: [s] without a fresh command for this long the arm holds where it is; 0: never.
        velocity_scale: joint speed limit as a fraction of the Panda's V_MAX, in (0, 1].
        initial_q: [rad] (7,) configuration at reset.
        frame_id: frame of the published cloud and poses.
        camera: the depth camera.
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

"""The simulator core: the Panda on its table in a scenario, stepped by MuJoCo. No ROS.

    sim = Sim(load_scenario("tabletop", seed=0))
    sim.set_command(q_target)          # (7,) rad, validated and clamped (a position target)
    sim.set_trajectory(t, q, dq, ddq)  # or a trajectory, followed as a JointTrajectoryController does
    sim.step(50)                       # 50 physics steps (0.1 s at the default 2 ms)
    state = sim.get_state()            # time, q, dq, end-effector pose
    cloud = sim.point_cloud()          # (N, 3) float32 in world, robot removed (the first camera's)
    clouds = {n: sim.point_cloud(n) for n in sim.camera_names}  # every depth camera's
    sim.in_collision()                 # arm/hand touching an object or the table now
    sim.nearest_object()               # (distance [m], name): the arm's clearance to the scenario objects

One command source at a time: a trajectory takes the arm over as it arrives (from the current setpoint) and
position targets are refused while it runs (from its receipt to its end); after it ends, the next position
target takes over from where it holds. (A planner that publishes both, its trajectory segments and the targets
they end at, is therefore executed through its trajectories.)

Not thread-safe: use it from one thread (the camera's OpenGL context belongs to the capturing thread).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import mujoco
import numpy as np
from scipy.spatial.transform import Rotation

from sim_bridge.camera import DepthCamera
from sim_bridge.camera_config import CameraConfig
from sim_bridge.camera_frame import mujoco_from_optical
from sim_bridge.camera_rig import RigCamera, camera_rig
from sim_bridge.command import CommandResult, JointCommand
from sim_bridge.heap import release_freed_memory
from sim_bridge.mjcf import DEPTH_CAMERA, OBJECT_PREFIX, TCP_SITE, build_scene, extra_camera_name
from sim_bridge.scenario import Scenario
from sim_bridge.sim_config import SimConfig
from sim_bridge.trajectory_follower import TrajectoryFollower

POSITION, TRAJECTORY = "position", "trajectory"
"""The command sources of :class:`Sim`: position targets (set_command) and trajectories (set_trajectory)."""
TRAJECTORY_HOLD_S = 0.25
"""[s] after a trajectory's end, position targets still wait this long (Sim.trajectory_owns)"""

DISTANCE_CUTOFF_M = 0.5
"""[m] :meth:`Sim.nearest_object` reports distances up to this bound (farther objects: the cutoff)."""


@dataclass(frozen=True)
class SimState:
    """The robot's state at one instant.

    Attributes:
        time: [s] simulated time since the last reset.
        q: (7,) [rad] joint positions; dq: (7,) [rad/s] joint velocities.
        setpoint: (7,) [rad] the actuators' current position setpoint.
        tcp_position: (3,) [m] panda_hand_tcp in world; tcp_quaternion_xyzw: (4,).
    """

    time: float
    q: np.ndarray
    dq: np.ndarray
    setpoint: np.ndarray
    tcp_position: np.ndarray
    tcp_quaternion_xyzw: np.ndarray


class Sim:
    """MuJoCo simulation of one scenario.

    Args:
        scenario: the scene to build.
        config: settings (the cameras, command interface, timestep, initial configuration, seed).
        cameras: settings of the cameras config.cameras lists other than ``camera`` (sim_bridge/camera_rig.py).
    """

    def __init__(
        self, scenario: Scenario, config: SimConfig | None = None, cameras: Mapping[str, CameraConfig] | None = None
    ):
        self.config = config or SimConfig()
        self.cameras: dict[str, CameraConfig] = dict(cameras or {})
        """settings of the cameras config.cameras lists other than ``camera`` (their ``<name>.*`` parameters)"""
        self._cameras: dict[str, DepthCamera] = {}
        self.rig: tuple[RigCamera, ...] = ()
        self.reset(scenario)

    # ------------------------------------------------------------------ lifecycle
    def reset(self, scenario: Scenario | None = None) -> None:
        """Rebuild the scene (of `scenario`, or the current one) and put the arm at config.initial_q.

        The cameras are rebuilt (camera_rig of config, the scenario and self.cameras); their noise restarts from
        config.seed (-1: fresh entropy).
        """
        self.scenario = scenario if scenario is not None else self.scenario
        rig = camera_rig(self.config, self.scenario, self.cameras)
        scene = build_scene(self.scenario, rig[0].config, [(c.name, c.config) for c in rig[1:]])
        self.model = scene.model
        self.model.opt.timestep = self.config.timestep
        self._robot_geoms = scene.robot_geoms
        names = [self.model.geom(g).name for g in range(self.model.ngeom)]
        self._distance_pairs = [
            (int(r), int(o))
            for r in np.flatnonzero(scene.robot_geoms)
            for o in range(self.model.ngeom)
            if names[o].startswith(OBJECT_PREFIX)
        ]
        self._moving = scene.moving
        self.data = mujoco.MjData(self.model)
        q0 = np.asarray(self.config.initial_q, dtype=float)
        self.data.qpos[:7] = q0
        self.data.ctrl[:7] = q0
        self.command = JointCommand(
            q0, self.config.command_period, self.config.command_timeout, self.config.velocity_scale
        )
        self.follower = TrajectoryFollower(q0)
        self.source = POSITION
        """the command source that owns the setpoint: POSITION (set_command) or TRAJECTORY (set_trajectory)"""
        self._tcp = self.model.site(TCP_SITE).id
        self._place_moving_objects()
        mujoco.mj_forward(self.model, self.data)
        self._touched = self.in_collision()
        self.close()
        self.rig = rig
        seed = None if self.config.seed < 0 else self.config.seed
        for i, cam in enumerate(rig):  # the first camera's noise is seeded as the one camera's always was
            rng = np.random.default_rng(seed if seed is None or i == 0 else [seed, i])
            mjcf_name = DEPTH_CAMERA if i == 0 else extra_camera_name(cam.name)
            self._cameras[cam.name] = DepthCamera(self.model, self._robot_geoms, cam.config, rng, mjcf_name)
        release_freed_memory()  # the old scene's buffers: otherwise the RSS wanders with the scenes held

    def close(self) -> None:
        """Release the cameras' OpenGL contexts."""
        for camera in self._cameras.values():
            camera.close()
        self._cameras = {}

    # ------------------------------------------------------------------ commands and stepping
    def set_command(self, q: np.ndarray) -> CommandResult:
        """New joint position target q (7,) [rad]: NaN/inf refused, out-of-limit joints clamped; refused while a
        trajectory runs."""
        if self.trajectory_owns():
            return CommandResult(False, reason="a trajectory is being executed (trajectories have precedence)")
        self.source = POSITION
        return self.command.set(q, self.data.time)

    def set_trajectory(
        self,
        times: np.ndarray,
        positions: np.ndarray,
        velocities: np.ndarray | None = None,
        accelerations: np.ndarray | None = None,
        stamp: float = 0.0,
    ) -> str:
        """Follow a trajectory from its start time as a JointTrajectoryController does (TrajectoryFollower: it
        replaces the current one at its start, from the commanded state; the arm holds its last point after the
        end); '' when accepted, else why it was refused (the arm keeps its current command).

        Args:
            times: (K,) time from start [s], >= 0, strictly increasing.
            positions: (K, 7) [rad]; velocities (K, 7) [rad/s] and accelerations (K, 7) [rad/s^2] or None.
            stamp: start time [s] in sim time; 0 means now.
        """
        if self.source == POSITION:
            self.follower.hold(self.command.setpoint)  # taken over from the position setpoint, at rest
        reason = self.follower.set_trajectory(times, positions, velocities, accelerations, stamp, self.data.time)
        if not reason:
            self.source = TRAJECTORY
        return reason

    def trajectory_running(self) -> bool:
        """True from the receipt of a trajectory to its end."""
        return self.source == TRAJECTORY and self.data.time < self.follower.end_time()

    def trajectory_owns(self) -> bool:
        """True from the receipt of a trajectory to TRAJECTORY_HOLD_S after its end: position targets are refused
        meanwhile. A planner that sends each tick both as a segment and as a position target (the `planner`) must
        not hand the arm to its position target when a tick comes a little late: the setpoint would run ahead
        toward that target and jump back when the next segment arrives (a jolt of 10 rad/s^2 on joint 2)."""
        return self.source == TRAJECTORY and self.data.time < self.follower.end_time() + TRAJECTORY_HOLD_S

    def step(self, n: int = 1) -> None:
        """Advance n physics steps: setpoint, moving objects, dynamics; contacts are latched for
        :meth:`collided_since_last_check`."""
        dt = self.model.opt.timestep
        for _ in range(n):
            if self.source == TRAJECTORY:
                self.command.reset(self.follower.sample(self.data.time)[0])  # the setpoint follows the trajectory
                self.data.ctrl[:7] = self.command.setpoint
            else:
                self.data.ctrl[:7] = self.command.advance(self.data.time, dt)
            mujoco.mj_step(self.model, self.data)
            self._place_moving_objects()
            if not self._touched and self.data.ncon:
                self._touched = self.in_collision()

    def _place_moving_objects(self) -> None:
        for obj, mocap_id in self._moving:
            self.data.mocap_pos[mocap_id] = obj.position_at(self.data.time)

    # ------------------------------------------------------------------ observations
    def get_state(self) -> SimState:
        """Joint state, setpoint and end-effector pose now."""
        quat = np.zeros(4)
        mujoco.mju_mat2Quat(quat, self.data.site_xmat[self._tcp])
        return SimState(
            time=float(self.data.time),
            q=self.data.qpos[:7].copy(),
            dq=self.data.qvel[:7].copy(),
            setpoint=self.command.setpoint.copy(),
            tcp_position=self.data.site_xpos[self._tcp].copy(),
            tcp_quaternion_xyzw=np.r_[quat[1:], quat[0]],
        )

    @property
    def camera_names(self) -> tuple[str, ...]:
        """Names of the depth cameras, in order (camera_rig: the listed ones, then the scenario's)."""
        return tuple(c.name for c in self.rig)

    def point_cloud(self, camera: str | None = None) -> np.ndarray:
        """Cloud (N, 3) float32 [m] in world of depth camera `camera` (None: the first), robot points removed
        (see CameraConfig). KeyError for an unknown camera."""
        return self._camera(camera).point_cloud(self.data)

    def camera_pose(self, camera: str | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Depth camera `camera`'s (None: the first) optical centre (3,) [m] and orientation quaternion_xyzw (4,)
        in world, as published on ``<camera>/pose``: MuJoCo's camera frame (x right, y up, looking along -z;
        sim_bridge/camera_frame.py). The optical-frame pose is ``camera_transform``."""
        pose = self.camera_transform(camera)
        return pose[:3, 3], Rotation.from_matrix(mujoco_from_optical(pose[:3, :3])).as_quat()

    def camera_transform(self, camera: str | None = None) -> np.ndarray:
        """Depth camera `camera`'s (None: the first) (4, 4) camera-to-world transform, optical frame
        (data/camera.py: z forward, x right, y down); its clouds are the depth image unprojected with it."""
        return self._camera(camera).pose(self.data)

    def _camera(self, name: str | None) -> DepthCamera:
        name = self.rig[0].name if name is None else name
        if name not in self._cameras:
            raise KeyError(f"no depth camera {name!r} (cameras: {list(self._cameras)})")
        return self._cameras[name]

    def target_pose(self) -> tuple[np.ndarray, np.ndarray] | None:
        """The scenario target now: position (3,) [m] and quaternion_xyzw (4,), or None."""
        return self.scenario.target_pose_at(self.data.time)

    def contacts(self) -> list[tuple[str, str]]:
        """(robot geom, scene geom) names of every current contact between the arm and the scene."""
        pairs = []
        for c in self.data.contact[: self.data.ncon]:
            g1, g2 = int(c.geom1), int(c.geom2)
            r1, r2 = self._robot_geoms[g1], self._robot_geoms[g2]
            if r1 != r2:
                robot, other = (g1, g2) if r1 else (g2, g1)
                pairs.append((self.model.geom(robot).name, self.model.geom(other).name))
        return pairs

    def nearest_object(self, cutoff: float = DISTANCE_CUTOFF_M) -> tuple[float, str]:
        """The arm's clearance to the scenario objects now (the table is not one), from MuJoCo's geom distance.

        Returns:
            (distance [m], object name): the smallest signed distance between any robot geom (links, hand,
            fingers) and any scenario object, negative when they interpenetrate; (cutoff, "") when every
            object is farther than `cutoff` [m] or the scenario has none.
        """
        best, name = float(cutoff), ""
        for robot, other in self._distance_pairs:
            d = mujoco.mj_geomDistance(self.model, self.data, robot, other, best, None)
            if d < best:
                best, name = float(d), self.model.geom(other).name[len(OBJECT_PREFIX) :]
        return best, name

    def in_collision(self) -> bool:
        """True if the arm or hand touches any scene object or the table now."""
        return bool(self.contacts())

    def collided_since_last_check(self) -> bool:
        """True if the arm touched the scene at any step since the previous call (then clears the latch)."""
        touched = self._touched or self.in_collision()
        self._touched = False
        return touched

    def warnings(self) -> dict[str, int]:
        """MuJoCo warnings raised since the reset: {name: count} (empty when healthy)."""
        return {mujoco.mjtWarning(i).name: int(w.number) for i, w in enumerate(self.data.warning) if w.number > 0}

"""The closed loop's IK servo near a moving goal: it tracks without the latent optimisation's lag, stays within
the velocity limit, and never commands a segment the hard check refuses (a latent step is taken instead)."""

from __future__ import annotations

import numpy as np

from latent_planner_ros.planning.amp_ls import AmpLs, AmpLsConfig
from latent_planner_ros.planning.closed_loop import ClosedLoopConfig, ClosedLoopController
from latent_planner_ros.planning.evasion import Evader
from latent_planner_ros.planning.geometric_backend import GeometricBackend
from latent_planner_ros.planning.goal import Goal
from latent_planner_ros.robot.limits import Q_READY, V_MAX
from latent_planner_ros.robot.panda import load_panda

DOWN = np.diag([1.0, -1.0, -1.0])
SPEED = 0.1  # [m/s] along y


def _track(vae, servo_m: float, cloud: np.ndarray, ticks: int = 50):
    """A goal moving at SPEED, starting at the ready pose's TCP; an arm that is where the last command sent it.
    Returns (TCP errors [m] per tick, command sources, states (ticks + 1, 7), the planner)."""
    planner = AmpLs(vae, GeometricBackend(), AmpLsConfig(collision_backend="geometric"))
    c = ClosedLoopController(planner, ClosedLoopConfig(servo_radius_m=servo_m, goal_lead_s=0.0))
    panda = load_panda()
    q = Q_READY.copy()
    start = panda.fk(q).translation
    errors, sources, states = [], [], [q.copy()]
    for k in range(ticks):
        now = 0.1 * k
        goal = Goal(start + np.array([0.0, SPEED * now, 0.0]), DOWN)
        c.set_goal(goal, now)
        c.set_joint_state(q, now)
        c.set_scene(cloud, now, cloud=cloud)  # as the planner node: the cloud for the checks and the watch
        out = c.tick(now)
        if out.command is not None:
            q = out.command
        states.append(q.copy())
        errors.append(float(np.linalg.norm(panda.fk(q).translation - goal.position)))
        sources.append(out.values.get("command_source"))
    return np.array(errors), sources, np.array(states), planner


def test_the_servo_tracks_a_moving_goal_within_a_tick_of_motion(shipped_vae):
    empty = np.zeros((0, 3))
    servo, sources, states, _ = _track(shipped_vae, 0.1, empty)
    local, _, _, _ = _track(shipped_vae, 0.0, empty)
    assert sources.count("servo") > 30
    # an arm one tick behind: SPEED * 0.1 s = 1 cm, plus the IK's few iterations
    assert np.median(servo[20:]) < 0.013, servo
    assert np.median(servo[20:]) < np.median(local[20:]), (servo, local)
    steps = np.abs(np.diff(states, axis=0))
    assert np.all(steps <= 0.5 * V_MAX * 0.1 + 1e-9)  # speed_scale 0.5 of the velocity limits per 0.1 s tick


def test_a_servo_segment_the_hard_check_refuses_is_never_commanded(shipped_vae):
    # a wall of points across the goal's way 25 cm ahead of the start: the goal passes through it (a tracked target
    # may), the arm must not
    panda = load_panda()
    start = panda.fk(Q_READY).translation
    xs, zs = np.meshgrid(np.linspace(-0.15, 0.15, 31), np.linspace(-0.15, 0.3, 46))
    wall = np.stack([start[0] + xs.ravel(), np.full(xs.size, start[1] + 0.25), start[2] + zs.ravel()], axis=1)
    errors, sources, states, planner = _track(shipped_vae, 0.1, wall, ticks=40)
    assert "servo" in sources and set(sources) - {"servo"}  # servoing until the wall, other commands after
    planner.backend.set_scene(wall)
    for a, b in zip(states[:-1], states[1:], strict=True):
        assert planner.segment_free(a, b)
    clearance = Evader(0.05)
    clearance.add_cloud(wall, 0.0)
    for source, q in zip(sources, states[1:], strict=True):  # a servo command keeps servo_clearance_m (5 cm)
        assert source != "servo" or clearance.least_clearance(q) >= 0.05
    assert panda.fk(states[-1]).translation[1] < start[1] + 0.25  # still on this side of the wall


def _cube(centre: np.ndarray, half: float = 0.025, step: float = 0.01) -> np.ndarray:
    """The surface points (N, 3) [m] of a cube of half edge `half` [m] around centre (3,) [m], `step` apart."""
    g = np.arange(-half, half + 1e-9, step)
    x, y, z = np.meshgrid(g, g, g, indexing="ij")
    pts = np.stack([x.ravel(), y.ravel(), z.ravel()], axis=1)
    return centre + pts[np.abs(pts).max(axis=1) >= half - 1e-9]


def _track_moving(vae, obstacle_at, ticks: int = 40):
    """As _track, with a cloud that moves: obstacle_at(t [s], goal position (3,)) -> points (N, 3) [m]. Returns
    (TCP errors [m], command sources, states (ticks + 1, 7), the clouds per tick)."""
    planner = AmpLs(vae, GeometricBackend(), AmpLsConfig(collision_backend="geometric"))
    c = ClosedLoopController(planner, ClosedLoopConfig(servo_radius_m=0.1))  # the default lead: the arm goes ahead
    panda = load_panda()
    q = Q_READY.copy()
    start = panda.fk(q).translation
    errors, sources, states, clouds = [], [], [q.copy()], []
    for k in range(ticks):
        now = 0.1 * k
        goal = Goal(start + np.array([0.0, SPEED * now, 0.0]), DOWN)
        cloud = obstacle_at(now, goal.position)
        c.set_goal(goal, now)
        c.set_joint_state(q, now)
        c.set_scene(cloud, now, cloud=cloud)
        out = c.tick(now)
        if out.command is not None:
            q = out.command
        states.append(q.copy())
        clouds.append(cloud)
        errors.append(float(np.linalg.norm(panda.fk(q).translation - goal.position)))
        sources.append(out.values.get("command_source"))
    return np.array(errors), sources, np.array(states), clouds


def test_the_servo_tracks_a_target_that_travels_under_the_hand(shipped_vae):
    """A conveyor's target: a cube 10 cm under the goal moves with it, the arm chasing the goal led by its velocity:
    the cube is no obstacle coming at the arm, so the servo goes on and keeps the hand clear of it."""
    below = np.array([0.0, 0.0, -0.125])  # the cube's top face 10 cm under the TCP goal
    errors, sources, states, clouds = _track_moving(shipped_vae, lambda t, goal: _cube(goal + below))
    assert sources.count("servo") > 25, sources
    assert np.median(errors[20:]) < 0.04, errors  # the lead: 0.3 s x 10 cm/s = 3 cm ahead of the goal
    watch = Evader(0.05)
    for q, cloud in zip(states[1:], clouds, strict=True):
        watch.add_cloud(cloud, 0.0)
        assert watch.least_clearance(q) >= 0.05  # the hand never comes near the cube


def test_the_servo_yields_to_an_obstacle_coming_at_the_arm(shipped_vae):
    """A block comes at the hand along the goal's way at 15 cm/s: no servo command lets it within
    servo_clearance_m (5 cm) of the commanded arm by the next tick."""
    start = load_panda().fk(Q_READY).translation

    def block(t, goal):
        return _cube(start + np.array([0.0, 0.35 - 0.15 * t, 0.0]), half=0.04)

    errors, sources, states, clouds = _track_moving(shipped_vae, block, ticks=25)
    assert "servo" in sources and set(sources) - {"servo"}  # servoing while the block is far, not when it is near
    watch = Evader(0.05)
    for k, (source, q) in enumerate(zip(sources, states[1:], strict=True)):
        if source == "servo" and k + 1 < len(clouds):
            watch.add_cloud(clouds[k + 1], 0.0)
            assert watch.least_clearance(q) >= 0.05, k

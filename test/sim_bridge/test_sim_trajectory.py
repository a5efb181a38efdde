"""The sim's two command sources: trajectories followed as a JointTrajectoryController does, position targets
refused while a trajectory runs and taking over after its end."""

import mujoco
import numpy as np

from latent_planner_ros.planning.motion_limits import MotionLimits
from latent_planner_ros.planning.time_parameterisation import jerk_limited_trajectory
from latent_planner_ros.robot.limits import Q_READY
from sim_bridge.sim import POSITION, TRAJECTORY


def test_a_jerk_limited_trajectory_is_followed_to_its_end_and_held(make_sim):
    sim = make_sim("empty")
    goal = Q_READY + np.array([0.4, -0.2, 0.3, 0.3, -0.2, 0.3, 0.4])
    traj = jerk_limited_trajectory(np.stack([Q_READY, goal]), MotionLimits())
    assert sim.set_trajectory(traj.times, traj.positions, traj.velocities, traj.accelerations) == ""
    assert sim.source == TRAJECTORY and sim.trajectory_running()
    half = int(round(traj.duration / 2 / sim.model.opt.timestep))
    sim.step(half)
    expected = traj.positions[np.searchsorted(traj.times, sim.data.time)]
    np.testing.assert_allclose(sim.get_state().setpoint, expected, atol=0.02)
    sim.step(int(round(traj.duration / sim.model.opt.timestep)))  # past the end: held there
    assert not sim.trajectory_running()
    np.testing.assert_allclose(sim.get_state().setpoint, goal, atol=1e-9)
    sim.step(250)
    np.testing.assert_allclose(sim.get_state().q, goal, atol=0.01)


def test_position_targets_are_refused_while_a_trajectory_runs_then_take_over(make_sim):
    sim = make_sim("empty")
    target = Q_READY + 0.1
    assert sim.set_trajectory([0.5], [target]) == ""
    sim.step(50)
    result = sim.set_command(Q_READY)
    assert not result.accepted and "trajectory" in result.reason
    sim.step(250)  # 0.6 s: the trajectory has ended, but a late segment of its sender may still come
    assert not sim.set_command(Q_READY).accepted and sim.source == TRAJECTORY
    sim.step(100)  # 0.8 s: TRAJECTORY_HOLD_S after its end
    assert sim.set_command(Q_READY).accepted and sim.source == POSITION
    sim.step(1)
    assert np.all(np.abs(sim.get_state().setpoint - target) < 0.01)  # from where the trajectory left the arm
    sim.step(500)
    np.testing.assert_allclose(sim.get_state().setpoint, Q_READY, atol=1e-9)


def test_a_trajectory_takes_over_from_the_position_setpoint(make_sim):
    sim = make_sim("empty")
    assert sim.set_command(Q_READY + 0.2).accepted
    sim.step(25)  # halfway along the linear approach
    setpoint = sim.get_state().setpoint.copy()
    assert sim.set_trajectory([1.0], [Q_READY]) == ""
    sim.step(1)
    np.testing.assert_allclose(sim.get_state().setpoint, setpoint, atol=0.01)
    assert sim.set_trajectory([0.1, 0.05], [Q_READY, Q_READY]) != ""  # refused: the arm keeps the first one
    sim.step(600)
    np.testing.assert_allclose(sim.get_state().setpoint, Q_READY, atol=1e-9)


def test_segments_move_the_arm_smoothly_where_position_targets_jerk_it(make_sim):
    """The same 10 Hz targets as position setpoints and as the planner's replacing segments: the measured joint
    acceleration stays within 1.25 times the segments' limit, while position targets exceed twice it."""
    from latent_planner_ros.nodes.segment_chain import SegmentChain

    limits = MotionLimits()
    goal = Q_READY + np.array([0.5, 0.25, -0.2, 0.35, 0.1, -0.2, 0.3])
    peaks = {}
    for mode in ("position", "segments"):
        sim, chain, velocities = make_sim("empty"), SegmentChain(), []
        for _ in range(40):
            q = sim.get_state().q
            target = q + np.clip(goal - q, -0.1 * limits.v_max, 0.1 * limits.v_max)
            if mode == "position":
                assert sim.set_command(target).accepted
            else:
                segment = chain.next(sim.data.time, target, q, limits, 0.1)
                assert (
                    sim.set_trajectory(segment.times, segment.positions, segment.velocities, segment.accelerations)
                    == ""
                )
            for _ in range(10):
                sim.step(5)
                velocities.append(sim.get_state().dq)
        peaks[mode] = (np.abs(np.diff(velocities, axis=0)) / 0.01).max(axis=0)
    assert np.all(peaks["segments"] <= 1.25 * limits.a_max), peaks
    assert np.all(peaks["position"] > 2.0 * limits.a_max[1]), peaks


def test_a_trajectory_beyond_the_limits_is_refused_and_the_arm_holds(make_sim):
    """Finite velocities of 1e300 rad/s once reached MuJoCo's controls as NaN, and MuJoCo reset the simulation
    (the arm jumped to its start pose); found by `bench fuzz` with the bad-control invariant."""
    sim = make_sim("empty")
    sim.step(100)
    q_before = sim.get_state().q.copy()
    reason = sim.set_trajectory(np.array([0.0, 0.5]), np.stack([q_before, q_before + 0.1]), np.full((2, 7), 1e300))
    assert "velocity of panda_joint1" in reason and "beyond its limit" in reason
    sim.step(100)
    assert sim.data.warning[mujoco.mjtWarning.mjWARN_BADCTRL].number == 0
    assert sim.source == POSITION
    np.testing.assert_allclose(sim.get_state().q, q_before, atol=0.01)


def test_a_late_tick_after_a_segment_ended_starts_from_the_held_point_not_the_lagging_arm(make_sim):
    """The arm tracks the segments with a lag. When the next tick comes only as a segment ends, the controller
    holds that end, which the arm has not reached; the next segment starts at rest from the held end. Started from
    the measured state instead, the controller's command jumped back to where the arm lagged and yanked it: 1.8
    times the acceleration limit on joint 2 here (12-20 rad/s^2 through the node, test_execution)."""
    from latent_planner_ros.nodes.segment_chain import SegmentChain

    limits = MotionLimits()
    step = 0.4 * limits.v_max * 0.1 * np.array([1, 1, -1, 1, 1, -1, 1])  # [rad] per tick
    sim, chain, velocities, target = make_sim("empty"), SegmentChain(), [], Q_READY.copy()
    for k in range(24):
        target = target + (step if k < 10 else 0.1 * step if k == 10 else -step)  # out, nearly stop, back
        segment = chain.next(sim.data.time, target, sim.get_state().q, limits, 0.1)
        assert sim.set_trajectory(segment.times, segment.positions, segment.velocities, segment.accelerations) == ""
        ticks = int(round(segment.duration / 0.01)) if k == 10 else 10  # tick 11 comes as segment 10 ends
        for _ in range(ticks):
            sim.step(5)
            velocities.append(sim.get_state().dq)
        if k == 10:
            lag = np.abs(segment.positions[-1] - sim.get_state().q).max()
            assert 0.002 < lag < 0.05, lag  # the case: the arm behind the held end, near it
    peaks = (np.abs(np.diff(velocities, axis=0)) / 0.01).max(axis=0)
    assert np.all(peaks <= 1.25 * limits.a_max), peaks / limits.a_max

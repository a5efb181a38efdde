"""msg_adapters.trajectory: execution trajectories (positions, velocities, accelerations) and their validation."""

import numpy as np
import pytest
from builtin_interfaces.msg import Duration
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

from latent_planner_ros.planning.time_parameterisation import jerk_limited_trajectory
from latent_planner_ros.robot.limits import JOINT_NAMES, Q_READY
from msg_adapters.errors import AdapterError
from msg_adapters.trajectory import joint_path_to_trajectory, trajectory_to_execution


def test_a_jerk_limited_trajectory_round_trips_with_velocities_and_accelerations():
    traj = jerk_limited_trajectory(np.stack([Q_READY, Q_READY + 0.3]), dt=0.02)
    msg = joint_path_to_trajectory(
        traj.positions, traj.times, velocities=traj.velocities, accelerations=traj.accelerations
    )
    assert all(len(p.accelerations) == 7 for p in msg.points)
    t, q, dq, ddq = trajectory_to_execution(msg)
    np.testing.assert_allclose(t, traj.times, atol=1e-9)
    np.testing.assert_array_equal(q, traj.positions)
    np.testing.assert_array_equal(dq, traj.velocities)
    np.testing.assert_array_equal(ddq, traj.accelerations)


def test_columns_are_reordered_and_missing_derivatives_are_none():
    names = list(reversed(JOINT_NAMES))
    msg = joint_path_to_trajectory(np.arange(14.0).reshape(2, 7), [0.5, 1.0], names=names)
    t, q, dq, ddq = trajectory_to_execution(msg)
    np.testing.assert_array_equal(q[:, 0], [6.0, 13.0])
    assert dq is None and ddq is None


def _msg(names=JOINT_NAMES, times=(0.1, 0.2), positions=None, velocities=None):
    msg = JointTrajectory(joint_names=list(names))
    for i, t in enumerate(times):
        point = JointTrajectoryPoint(positions=positions if positions is not None else [0.0] * len(names))
        point.time_from_start = Duration(sec=int(t), nanosec=int(round((t % 1) * 1e9)))
        if velocities is not None and i == 0:
            point.velocities = velocities
        msg.points.append(point)
    return msg


@pytest.mark.parametrize(
    ("msg", "match"),
    [
        (_msg(times=()), "no points"),
        (_msg(names=JOINT_NAMES[:6]), "lacks joints"),
        (_msg(names=[*JOINT_NAMES, "panda_finger_joint1"]), "unknown joints"),
        (_msg(names=[f"fr3_joint{i}" for i in range(1, 8)]), "unknown joints"),
        (_msg(times=(0.2, 0.2)), "strictly increasing"),
        (_msg(times=(0.3, 0.2)), "strictly increasing"),
        (_msg(positions=[float("nan")] * 7), "NaN"),
        (_msg(positions=[0.0] * 6), "positions"),
        (_msg(velocities=[0.0] * 7), "velocities"),
        (_msg(velocities=[float("inf")] * 7, times=(0.1,)), "NaN or inf"),
    ],
)
def test_malformed_trajectories_are_refused_with_a_reason(msg, match):
    with pytest.raises(AdapterError, match=match):
        trajectory_to_execution(msg)

"""TrajectoryStreamer: targets follow the trajectory within limits, wait for a lagging arm, and finish."""

import numpy as np
import pytest

from latent_planner_ros.planning.time_parameterisation import time_parameterise
from latent_planner_ros.planning.trajectory_stream import TrajectoryStreamer
from latent_planner_ros.robot.limits import Q_MAX, Q_MIN, Q_READY, V_MAX


def _path() -> tuple[np.ndarray, np.ndarray]:
    q = np.stack([Q_READY, Q_READY + 0.6, Q_READY + [0.6, 0.6, 0.6, 0.6, -0.6, 0.6, -0.6]])
    return q, time_parameterise(q, 0.5)


def test_perfect_tracking_follows_the_path_and_finishes():
    q_path, times = _path()
    streamer = TrajectoryStreamer(q_path, times, period=0.1)
    q, commands = q_path[0].copy(), []
    for _ in range(200):
        command = streamer.next_command(q)
        if command is None:
            break
        assert np.all(command >= Q_MIN) and np.all(command <= Q_MAX)
        assert np.all(np.abs(command - q) <= V_MAX * 0.1 + 1e-12)
        commands.append(command)
        q = command
    assert streamer.done and np.allclose(q, q_path[-1])
    assert len(commands) <= int(np.ceil(times[-1] / 0.1)) + 2
    assert np.allclose(streamer.reference(times[1]), q_path[1])


def test_a_lagging_arm_holds_the_reference_and_never_gets_a_fast_target():
    q_path, times = _path()
    streamer = TrajectoryStreamer(q_path, times, period=0.1, lag_tol_rad=0.05)
    stuck = q_path[0].copy()
    for _ in range(10):
        command = streamer.next_command(stuck)  # the arm does not move
        assert np.all(np.abs(command - stuck) <= V_MAX * 0.1 + 1e-12)
    assert streamer.t == pytest.approx(0.1)  # advanced once, then waited
    far = stuck + 1.0  # far from the path: the step is scaled to the velocity limit
    assert np.all(np.abs(streamer.next_command(far) - far) <= V_MAX * 0.1 + 1e-12)


def test_mismatched_trajectory_is_refused():
    with pytest.raises(ValueError, match="must match"):
        TrajectoryStreamer(np.zeros((3, 7)), np.zeros(2))

"""A joint_trajectory stamped on the sim's published /clock is taken after a scene reset too: /clock runs on
across resets while the sim's own time restarts (every planner segment was refused as "stamped ahead" after the
first reset of a soak or conveyor run)."""

from __future__ import annotations

import numpy as np
import pytest
from builtin_interfaces.msg import Time

from latent_planner_ros.robot.limits import Q_READY
from msg_adapters import joint_path_to_trajectory
from sim_bridge.sim import TRAJECTORY
from test.nodes.sim_node import running_sim

pytestmark = pytest.mark.ros


@pytest.fixture
def sim():
    with running_sim() as node:
        yield node


def _segment(start_s: float):
    """A short still segment at the sim's current command, stamped start_s [s] on the published clock."""
    positions = np.repeat(np.asarray(Q_READY, dtype=float)[None], 3, axis=0)
    msg = joint_path_to_trajectory(positions, np.array([0.0, 0.1, 0.2]))
    msg.header.stamp = Time(sec=int(start_s), nanosec=int((start_s % 1.0) * 1e9))
    return msg


def test_a_segment_stamped_on_the_clock_is_taken_after_a_reset(sim):
    for _ in range(800):  # 8 s of sim time: more than the 5 s a stamp may lie ahead
        sim.runner.advance()
    sim.runner.reset()
    clock = sim.runner.clock
    assert clock > 7.0 and sim.sim.data.time < 1.0  # /clock ran on, the sim's own time restarted
    sim._on_trajectory(_segment(clock + 0.05))
    assert sim.sim.source == TRAJECTORY  # taken, not refused as "stamped ahead of the sim's clock"
    assert sim.runner.to_sim_time(clock) == pytest.approx(sim.sim.data.time)

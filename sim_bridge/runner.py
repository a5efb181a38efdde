"""Real-time pacing and the publication schedule of a running simulation. No ROS.

A :class:`Runner` advances a :class:`~sim_bridge.sim.Sim` one joint-state period at a time and says which
outputs are due (each depth camera at its rate or ``cloud_rate``, pictures at a recording rate);
:meth:`Runner.wait` then sleeps until the wall clock catches up with ``real_time_factor`` while letting the
caller serve callbacks.
The clock it reports is monotonic across resets (downstream nodes on sim time never see it go back).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass

from sim_bridge.scenario import Scenario
from sim_bridge.sim import Sim


class RateSchedule:
    """Fires at a fixed rate [Hz] of simulated time: `due(t)` is True once per period (first at t = 0)."""

    def __init__(self, rate_hz: float):
        self.period = 1.0 / float(rate_hz)
        self.next_time = 0.0

    def due(self, t: float, tolerance: float = 1e-9) -> bool:
        if t + tolerance < self.next_time:
            return False
        # skip missed periods rather than firing in a burst
        self.next_time += self.period * max(1, math.floor((t + tolerance - self.next_time) / self.period) + 1)
        return True


@dataclass(frozen=True)
class Tick:
    """What happened in one call to :meth:`Runner.advance`.

    Attributes:
        clock: [s] simulated time since the runner started (monotonic across resets).
        cloud_due: the target pose should be published now (at cloud_rate).
        frame_due: a recording frame should be taken now.
        collided: the arm touched the scene during this period.
        clouds_due: names of the depth cameras whose cloud should be published now (each at its own rate).
    """

    clock: float
    cloud_due: bool
    frame_due: bool
    collided: bool
    clouds_due: tuple[str, ...] = ()


class Runner:
    """Steps `sim` in chunks of one joint-state period and paces them against the wall clock.

    Args:
        sim: the simulator (its config gives the rates and the real-time factor).
        frame_rate: [Hz] of recording frames in simulated time (0: no recording).
        wall_clock: a monotonic clock [s] (injectable for tests).
    """

    def __init__(self, sim: Sim, frame_rate: float = 0.0, wall_clock: Callable[[], float] = time.monotonic):
        self.sim = sim
        self.wall_clock = wall_clock
        self.real_time_factor = sim.config.real_time_factor
        self.frame_rate = frame_rate
        self._clock_offset = 0.0
        self._restart_schedules()
        self._anchor(settle=True)

    def _restart_schedules(self) -> None:
        c = self.sim.config
        self.steps_per_tick = max(1, round(1.0 / (c.joint_state_rate * c.timestep)))
        self._cloud = RateSchedule(c.cloud_rate)
        self._camera_schedules = {cam.name: RateSchedule(cam.config.rate or c.cloud_rate) for cam in self.sim.rig}
        self._frames = RateSchedule(self.frame_rate) if self.frame_rate > 0 else None

    def _anchor(self, settle: bool = False) -> None:
        self._wall0 = self.wall_clock()
        self._clock0 = self.clock
        self._settling = settle  # the first tick after a (re)start pays one-off costs (OpenGL context)

    @property
    def clock(self) -> float:
        """[s] simulated time since the runner started."""
        return self._clock_offset + self.sim.data.time

    def to_sim_time(self, clock: float) -> float:
        """[s] the sim's own time (`sim.data.time`, which restarts at every reset) of a time on the published clock."""
        return float(clock) - self._clock_offset

    def set_real_time_factor(self, factor: float) -> None:
        """Change the pace (0: as fast as possible) from now on."""
        self.real_time_factor = float(factor)
        self._anchor()

    def reset(self, scenario: Scenario | None = None) -> None:
        """``sim.reset(scenario)`` keeping the clock running (the new episode starts at the old clock)."""
        clock = self.clock
        self.sim.reset(scenario)
        self._clock_offset = clock - self.sim.data.time
        self._restart_schedules()
        self._anchor(settle=True)

    def advance(self) -> Tick:
        """Step one joint-state period and report what is due."""
        self.sim.step(self.steps_per_tick)
        t = self.sim.data.time
        return Tick(
            clock=self.clock,
            cloud_due=self._cloud.due(t),
            frame_due=self._frames is not None and self._frames.due(t),
            collided=self.sim.collided_since_last_check(),
            clouds_due=tuple(name for name, schedule in self._camera_schedules.items() if schedule.due(t)),
        )

    def wall_deadline(self) -> float | None:
        """Wall-clock time at which the simulation is on schedule, or None when running flat out."""
        if self.real_time_factor <= 0.0:
            return None
        return self._wall0 + (self.clock - self._clock0) / self.real_time_factor

    def wait(self, serve: Callable[[float], None], max_lag: float = 0.1) -> float:
        """Serve callbacks until the wall clock reaches the schedule; returns the lag [s] (> 0: behind).

        Args:
            serve: called with a timeout [s] (e.g. ``executor.spin_once``); called at least once (timeout 0).
            max_lag: [s] when the simulation falls further behind than this, the schedule restarts from
                now instead of racing to catch up (simulated time slips; rates stay steady).
        """
        deadline = self.wall_deadline()
        if deadline is None:
            serve(0.0)
            return 0.0
        now = self.wall_clock()
        lag = now - deadline
        if self._settling:
            self._settling = False
            self._anchor()
            serve(0.0)
            return 0.0
        if lag >= 0.0:
            serve(0.0)
            if lag > max_lag:
                self._anchor()
            return lag
        while now < deadline:
            serve(deadline - now)
            now = self.wall_clock()
        return 0.0

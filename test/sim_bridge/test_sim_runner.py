"""The runner: publication schedule in simulated time, real-time pacing, a clock that survives resets."""

from __future__ import annotations

import pytest

from sim_bridge.runner import RateSchedule, Runner


class FakeWall:
    """A wall clock that only moves when the runner waits (or when told to)."""

    def __init__(self):
        self.now = 100.0

    def __call__(self) -> float:
        return self.now

    def serve(self, timeout: float) -> None:
        self.now += timeout


def test_rate_schedule_fires_once_per_period_and_skips_missed_ones():
    schedule = RateSchedule(12.5)
    fired = [t for t in [k * 0.01 for k in range(1, 101)] if schedule.due(t)]
    assert len(fired) == 13  # t = 0.01, then every 0.08 s in [0, 1]
    late = RateSchedule(10.0)
    assert late.due(0.0) and late.due(0.55) and not late.due(0.58) and late.due(0.6)


def test_ticks_follow_the_configured_rates(make_sim):
    runner = Runner(make_sim("empty"), frame_rate=5.0)
    ticks = [runner.advance() for _ in range(100)]  # 1 s of joint states at 100 Hz
    assert ticks[-1].clock == pytest.approx(1.0)
    assert sum(t.cloud_due for t in ticks) == 13  # t = 0.01, 0.08, ..., 0.96
    assert sum(t.frame_due for t in ticks) == 6  # t = 0.01, 0.2, ..., 1.0
    assert not any(t.collided for t in ticks)


def test_real_time_pacing_with_a_fake_wall_clock(make_sim):
    for factor in (1.0, 4.0):
        wall = FakeWall()
        runner = Runner(make_sim("empty", real_time_factor=factor), wall_clock=wall)
        runner.advance()
        runner.wait(wall.serve)  # the first tick re-anchors (one-off start-up costs are not lag)
        start = wall.now
        for _ in range(50):
            runner.advance()
            assert runner.wait(wall.serve) == 0.0
        assert wall.now - start == pytest.approx(0.5 / factor)


def test_flat_out_and_lag_reporting(make_sim):
    wall = FakeWall()
    runner = Runner(make_sim("empty", real_time_factor=0.0), wall_clock=wall)
    for _ in range(10):
        runner.advance()
        assert runner.wait(wall.serve) == 0.0
    assert wall.now == 100.0  # never waits
    runner.set_real_time_factor(1.0)
    runner.advance()
    wall.now += 0.05  # a slow step: behind schedule, caught up over the next ticks
    assert runner.wait(wall.serve) == pytest.approx(0.04)
    wall.now += 0.3  # too slow: the schedule restarts from now instead of racing
    runner.advance()
    assert runner.wait(wall.serve) == pytest.approx(0.33)
    runner.advance()
    assert runner.wait(wall.serve) == 0.0 and wall.now == pytest.approx(100.36)


def test_clock_is_monotonic_across_resets(make_sim):
    runner = Runner(make_sim("empty"))
    for _ in range(30):
        runner.advance()
    before = runner.clock
    runner.reset()
    assert runner.sim.data.time == 0.0 and runner.clock == pytest.approx(before)
    assert runner.advance().clock == pytest.approx(before + 0.01)

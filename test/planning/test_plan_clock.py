"""PlanClock: exclusive nested sections."""

import pytest

from latent_planner_ros.planning.plan_clock import PlanClock


class FakeTime:
    def __init__(self):
        self.t = 0.0

    def __call__(self) -> float:
        return self.t


def test_nested_sections_are_exclusive_and_add_up():
    now = FakeTime()
    clock = PlanClock(now)
    with clock.section("steps"):
        now.t += 1.0
        with clock.section("check"):
            now.t += 2.0
        now.t += 0.5
        with clock.section("ik"):
            now.t += 0.25
            with clock.section("check"):
                now.t += 4.0
    with clock.section("check"):
        now.t += 8.0
    assert clock.totals() == pytest.approx({"steps_s": 1.5, "check_s": 14.0, "ik_s": 0.25})
    assert sum(clock.totals().values()) == pytest.approx(now.t)
    clock.reset()
    assert clock.totals() == {}


def test_a_section_left_by_an_exception_still_counts():
    now = FakeTime()
    clock = PlanClock(now)
    with pytest.raises(RuntimeError), clock.section("outer"):
        now.t += 1.0
        with clock.section("inner"):
            now.t += 2.0
            raise RuntimeError("x")
    with clock.section("outer"):
        now.t += 3.0
    assert clock.totals() == pytest.approx({"outer_s": 4.0, "inner_s": 2.0})

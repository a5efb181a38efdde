"""msg_adapters.plan_request: the GetPlan tolerance rule and the plan_result DiagnosticStatus."""

from __future__ import annotations

import math

import pytest
from builtin_interfaces.msg import Time
from diagnostic_msgs.msg import DiagnosticStatus

from msg_adapters import AdapterError, plan_result_status, plan_tolerance
from msg_adapters.plan_request import FAILED, REFUSED, SUCCESS, format_stamp


def _values(status: DiagnosticStatus) -> dict[str, str]:
    return {kv.key: kv.value for kv in status.values}


def test_tolerance_zero_is_the_default_and_a_positive_one_is_used():
    assert plan_tolerance(0.0, 0.01) == 0.01
    assert plan_tolerance(-0.0, 0.01) == 0.01
    assert plan_tolerance(0.005, 0.01) == 0.005
    assert plan_tolerance(2.0, 0.01) == 2.0


@pytest.mark.parametrize("bad", [-0.01, -math.inf, math.inf, math.nan])
def test_tolerance_nan_inf_or_negative_is_refused_with_a_reason(bad):
    with pytest.raises(AdapterError, match="tolerance must be 0"):
        plan_tolerance(bad, 0.01)


def test_success_is_ok_with_time_error_stamp_and_waypoints():
    status = plan_result_status("planner", SUCCESS, "reached", Time(sec=12, nanosec=50_000_000), 17, 0.0512, 0.0031)
    assert status.level == DiagnosticStatus.OK and status.name == "planner"
    assert status.message == "reached in 0.05 s"
    assert _values(status) == {
        "success": "true",
        "reason": "reached",
        "planning_time_s": "0.0512",
        "final_pos_err_m": "0.0031",
        "request_stamp": "12.050000000",
        "waypoints": "17",
    }


def test_failure_is_error_with_the_final_error_in_the_message():
    status = plan_result_status("ompl_planner", FAILED, "no progress", Time(sec=3), 0, 1.5, 0.12)
    assert status.level == DiagnosticStatus.ERROR
    assert status.message == "plan failed: no progress (error 120 mm)"
    values = _values(status)
    assert values["success"] == "false" and values["waypoints"] == "0" and values["final_pos_err_m"] == "0.12"


def test_refusal_is_error_and_leaves_out_what_is_not_known():
    status = plan_result_status("planner", REFUSED, "goal pose is not finite", Time(sec=1, nanosec=7))
    assert status.level == DiagnosticStatus.ERROR
    assert status.message == "refused: goal pose is not finite"
    assert _values(status) == {
        "success": "false",
        "reason": "goal pose is not finite",
        "request_stamp": "1.000000007",
        "waypoints": "0",
    }
    nan_err = plan_result_status("planner", FAILED, "no IK solution", Time(), 0, math.nan, math.nan)
    assert nan_err.message == "plan failed: no IK solution" and "final_pos_err_m" not in _values(nan_err)


def test_unknown_outcome_and_stamp_format():
    with pytest.raises(AdapterError, match="outcome"):
        plan_result_status("planner", "maybe", "", Time())
    assert format_stamp(Time(sec=0, nanosec=0)) == "0.000000000"

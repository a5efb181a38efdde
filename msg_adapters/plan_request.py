"""nav_msgs/GetPlan requests: the tolerance rule, and the outcome of a request as diagnostic_msgs/DiagnosticStatus."""

from __future__ import annotations

import math

from builtin_interfaces.msg import Time
from diagnostic_msgs.msg import DiagnosticStatus, KeyValue

from msg_adapters.errors import AdapterError

SUCCESS, FAILED, REFUSED = "success", "failed", "refused"
"""Outcomes of a plan request: planned, planned without reaching the goal, refused before planning."""


def plan_tolerance(tolerance: float, default_m: float) -> float:
    """The goal position tolerance [m] of a GetPlan request.

    0 means `default_m` (the node's configured tolerance); a finite positive value is the tolerance itself.

    Raises:
        AdapterError: NaN, inf or a negative tolerance (refused, not replaced by the default).
    """
    tol = float(tolerance)
    if not math.isfinite(tol) or tol < 0.0:
        raise AdapterError(f"tolerance must be 0 (the default) or a finite positive distance [m], got {tol:.6g}")
    return tol if tol > 0.0 else float(default_m)


def format_stamp(stamp: Time) -> str:
    """A builtin_interfaces/Time as "sec.nanosec" with nine digits of nanoseconds, e.g. "12.050000000"."""
    return f"{int(stamp.sec)}.{int(stamp.nanosec):09d}"


def plan_result_status(
    name: str,
    outcome: str,
    reason: str,
    request_stamp: Time,
    waypoints: int = 0,
    planning_time_s: float | None = None,
    final_pos_err_m: float | None = None,
) -> DiagnosticStatus:
    """The outcome of one GetPlan request as a DiagnosticStatus.

    name: the node's name; outcome: SUCCESS, FAILED or REFUSED; reason: the planner's reason ("reached",
    "no progress", ...) or why the request was refused; request_stamp: the goal's header stamp; waypoints: poses
    in the returned path; planning_time_s [s] and final_pos_err_m [m]: None (or NaN) when not known, and then
    left out of the values.

    Level OK on success, ERROR otherwise. Message: "reached in 0.05 s", "plan failed: no progress (error 120 mm)"
    or "refused: <reason>". Values: success (true/false), reason, planning_time_s, final_pos_err_m (where known),
    request_stamp ("sec.nanosec"), waypoints.

    Raises:
        AdapterError: an unknown outcome.
    """
    time_known = planning_time_s is not None and math.isfinite(planning_time_s)
    err_known = final_pos_err_m is not None and math.isfinite(final_pos_err_m)
    if outcome == SUCCESS:
        message = f"{reason} in {planning_time_s:.2f} s" if time_known else reason
    elif outcome == FAILED:
        err_mm = final_pos_err_m * 1000 if final_pos_err_m is not None and err_known else None
        message = f"plan failed: {reason}" + (f" (error {err_mm:.0f} mm)" if err_mm is not None else "")
    elif outcome == REFUSED:
        message = f"refused: {reason}"
    else:
        raise AdapterError(f"outcome must be one of {SUCCESS}, {FAILED}, {REFUSED}, got {outcome!r}")
    values = {"success": "true" if outcome == SUCCESS else "false", "reason": reason}
    if time_known:
        values["planning_time_s"] = f"{planning_time_s:.6g}"
    if err_known:
        values["final_pos_err_m"] = f"{final_pos_err_m:.6g}"
    values["request_stamp"] = format_stamp(request_stamp)
    values["waypoints"] = str(int(waypoints))
    level = DiagnosticStatus.OK if outcome == SUCCESS else DiagnosticStatus.ERROR
    status = DiagnosticStatus(level=level, name=name, message=message)
    status.values = [KeyValue(key=k, value=v) for k, v in values.items()]
    return status

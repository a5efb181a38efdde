"""A node's status as diagnostic_msgs/DiagnosticArray: one DiagnosticStatus with key/value pairs."""

from __future__ import annotations

from builtin_interfaces.msg import Time
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue


def status_array(
    name: str, level: int | bytes, message: str, values: dict, hardware_id: str = "", stamp: Time | None = None
) -> DiagnosticArray:
    """A DiagnosticArray holding one status.

    level: DiagnosticStatus.OK, WARN, ERROR or STALE (bytes) or their integer values 0-3;
    values: key -> value, floats written with 6 significant digits, everything else with str().
    """
    level = level if isinstance(level, bytes) else bytes([level])
    status = DiagnosticStatus(level=level, name=name, message=message, hardware_id=hardware_id)
    status.values = [KeyValue(key=k, value=f"{v:.6g}" if isinstance(v, float) else str(v)) for k, v in values.items()]
    msg = DiagnosticArray(status=[status])
    if stamp is not None:
        msg.header.stamp = stamp
    return msg

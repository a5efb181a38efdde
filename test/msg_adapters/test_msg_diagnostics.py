from builtin_interfaces.msg import Time
from diagnostic_msgs.msg import DiagnosticStatus

from msg_adapters.diagnostics import status_array


def test_status_array_holds_one_status_with_formatted_values():
    msg = status_array(
        "planner",
        DiagnosticStatus.WARN,
        "failed: no progress",
        {"tick_ms": 12.3456789, "state": "failed", "n": 3},
        hardware_id="amp_ls",
        stamp=Time(sec=5, nanosec=7),
    )
    assert len(msg.status) == 1
    status = msg.status[0]
    assert (status.name, status.message, status.hardware_id) == ("planner", "failed: no progress", "amp_ls")
    assert status.level == DiagnosticStatus.WARN
    assert {kv.key: kv.value for kv in status.values} == {"tick_ms": "12.3457", "state": "failed", "n": "3"}
    assert (msg.header.stamp.sec, msg.header.stamp.nanosec) == (5, 7)


def test_status_array_without_stamp_leaves_it_zero():
    msg = status_array("scene_encoder", DiagnosticStatus.OK, "ok", {})
    assert msg.status[0].values == [] and msg.header.stamp.sec == 0

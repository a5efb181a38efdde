"""The demo's status line says what the planner does and where its command came from."""

import io

import numpy as np

from latent_planner_ros.demo import StatusLine
from latent_planner_ros.evaluation.probes.trial_monitor import Live
from latent_planner_ros.robot.limits import Q_READY


def test_the_status_line_names_the_command_source():
    out = io.StringIO()
    line = StatusLine(30.0, stream=out)
    live = Live(q=Q_READY.copy(), target_position=np.array([0.5, 0.0, 0.4]), state="tracking", tick_ms=4.2)
    live.source = "plan"
    line(0.0, live)
    text = out.getvalue()
    assert "planner tracking (plan)" in text and "tick   4.2 ms" in text and "EE-target" in text
    out.truncate(0)
    line(6.0, Live(state="holding"))
    assert "planner holding " in out.getvalue() and "(" not in out.getvalue().split("planner")[1].split("|")[0]

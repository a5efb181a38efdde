"""`python -m latent_planner_ros demo` end to end: a short conveyor trial through the node suite."""

from __future__ import annotations

import json
import os
import random
import subprocess
import sys
from pathlib import Path

import psutil
import pytest

from latent_planner_ros.demo import parse_args
from latent_planner_ros.processes.node_suite import LAUNCH_ENV

REPO = Path(__file__).resolve().parents[1]

SUMMARY_KEYS = {
    "reached",
    "tracked",
    "success",
    "time_to_reach_s",
    "tracking_fraction",
    "min_obstacle_distance_m",
    "collisions",
    "contact_s",
    "tick_ms_p50",
    "tick_ms_p99",
    "missed_ticks",
    "planner_states",
    "backend",
    "nodes",
    "pictures",
}


def test_arguments_are_checked():
    args = parse_args([])
    assert args.duration == 30.0 and args.out == Path("demo_out")
    for bad in (["--duration", "0"], ["--real-time-factor", "50"], ["--domain-id", "300"]):
        with pytest.raises(SystemExit):
            parse_args(bad)


def _suite_leftovers(pid: int) -> list[str]:
    """Processes still alive that were started for the demo with pid `pid` (the suite's marker variable)."""
    alive = []
    for proc in psutil.process_iter():
        try:
            if proc.environ().get(LAUNCH_ENV) == str(pid) and proc.status() != psutil.STATUS_ZOMBIE:
                alive.append(f"{proc.pid}: {' '.join(proc.cmdline())}")
        except (psutil.NoSuchProcess, psutil.AccessDenied, psutil.ZombieProcess):
            pass
    return alive


@pytest.mark.ros
@pytest.mark.slow
@pytest.mark.timeout(150)
def test_short_conveyor_demo_runs_end_to_end(tmp_path):
    out = tmp_path / "demo"
    domain = random.SystemRandom().randint(1, 100)
    env = dict(os.environ, PYTHONUNBUFFERED="1")
    env["PYTHONPATH"] = os.pathsep.join([str(REPO), *filter(None, [os.environ.get("PYTHONPATH")])])
    cmd = [sys.executable, "-m", "latent_planner_ros", "demo", "--duration", "5", "--frames", "3"]
    cmd += ["--out", str(out), "--domain-id", str(domain)]
    proc = subprocess.Popen(cmd, cwd=REPO, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    try:
        output, _ = proc.communicate(timeout=130)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 0, output
    assert "[demo] t " in output and "Summary (5 s of simulated time" in output, output
    assert _suite_leftovers(proc.pid) == []

    summary = json.loads((out / "summary.json").read_text())
    assert SUMMARY_KEYS <= set(summary), SUMMARY_KEYS - set(summary)
    assert summary["duration_s"] == 5.0 and summary["scenario"] == "conveyor"
    assert summary["nodes"][0] == "sim" and summary["nodes"][-1] == "planner"
    # the ground-truth clearance arrived over sim/min_distance, the tick timings over planner/status,
    # the commands over joint_command
    assert summary["min_obstacle_distance_m"] is not None and 0.0 < summary["min_obstacle_distance_m"] <= 0.5
    assert summary["tick_ms_p50"] is not None and summary["ticks_reported"] >= 10
    assert summary["commands"] >= 10
    assert summary["collisions"] == 0
    assert sum(summary["planner_states"].values()) == pytest.approx(1.0)
    for name in ("tracking", "scene"):
        png = Path(summary["pictures"][name])
        assert png.is_file() and png.stat().st_size > 10_000, name
    assert (out / "nodes.log").stat().st_size > 0 and (out / "trial.npz").is_file()

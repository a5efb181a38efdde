"""A running node prints its threads' stacks on SIGUSR1 and carries on (node_main), then exits cleanly on SIGINT."""

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]


def _read_until(proc: subprocess.Popen, text: str, timeout_s: float) -> str:
    seen, t_end = "", time.monotonic() + timeout_s
    while time.monotonic() < t_end and text not in seen:
        line = proc.stdout.readline()
        if not line:
            break
        seen += line
    return seen


@pytest.mark.ros
@pytest.mark.slow
def test_sigusr1_prints_stacks_and_the_node_keeps_running():
    env = dict(os.environ, PYTHONUNBUFFERED="1", ROS_DOMAIN_ID="77")
    cmd = [sys.executable, "-m", "latent_planner_ros", "run", "ompl_planner"]
    proc = subprocess.Popen(cmd, cwd=REPO, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    try:
        assert "OMPL baseline ready" in _read_until(proc, "OMPL baseline ready", 60.0)
        proc.send_signal(signal.SIGUSR1)
        dump = _read_until(proc, "run_node", 10.0)
        assert "Current thread" in dump or "Thread 0x" in dump, dump
        assert "node_main.py" in dump and "run_node" in dump, dump
        time.sleep(0.5)
        assert proc.poll() is None, "the node died on SIGUSR1"
        proc.send_signal(signal.SIGINT)
        proc.communicate(timeout=20)
        assert proc.returncode == 0
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.communicate()

"""Bench worker processes end when the bench process that started them is killed."""

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

PARENT = """
import os, sys, time, multiprocessing as mp
from concurrent.futures import ProcessPoolExecutor
from latent_planner_ros.batch.workers import exit_with_parent
init = exit_with_parent if sys.argv[1] == "watch" else None
ex = ProcessPoolExecutor(1, mp.get_context("spawn"), initializer=init)
print(ex.submit(os.getpid).result(), flush=True)
time.sleep(60)
"""


def _alive(pid: int) -> bool:
    """True while pid runs (a zombie, exited but not yet reaped, counts as gone)."""
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except (FileNotFoundError, ProcessLookupError):
        return False
    return state != "Z"


def _worker_after_parent_killed(mode: str) -> bool:
    """Start a pool in a parent process, SIGKILL the parent; whether its worker is still alive 3 s later."""
    env = {**os.environ, "PYTHONPATH": str(Path(__file__).resolve().parents[2])}
    parent = subprocess.Popen([sys.executable, "-c", PARENT, mode], stdout=subprocess.PIPE, text=True, env=env)
    worker = int(parent.stdout.readline())
    try:
        assert _alive(worker)
        parent.send_signal(signal.SIGKILL)
        parent.wait(10)
        deadline = time.monotonic() + 3.0
        while _alive(worker) and time.monotonic() < deadline:
            time.sleep(0.1)
        return _alive(worker)
    finally:
        if _alive(worker):
            os.kill(worker, signal.SIGKILL)


def test_a_worker_exits_with_its_killed_parent():
    assert not _worker_after_parent_killed("watch")


def test_without_the_watch_a_worker_outlives_its_parent():
    assert _worker_after_parent_killed("plain")  # the failure the watch prevents

"""Joining a running Ray cluster that requires a token (Ray's default auth mode): the command joins it with the
token in its environment and is refused, in one line that says what to check, with another token."""

import json
import os
import secrets
import subprocess
import sys
from pathlib import Path

import pytest
import ray

pytestmark = pytest.mark.slow

REPO = Path(__file__).resolve().parents[2]
PORT = 6397


def _ray(args: list[str], env: dict, timeout: float = 120) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "ray.scripts.scripts", *args], env=env, capture_output=True,
                          text=True, timeout=timeout)  # fmt: skip


@pytest.fixture(scope="module")
def head():
    """A Ray head of one CPU started like `ray start --head` on a cluster machine, with a token; stopped after."""
    token = secrets.token_hex(32)
    env = {**os.environ, "RAY_AUTH_MODE": "token", "RAY_AUTH_TOKEN": token, "RAY_USAGE_STATS_ENABLED": "0"}
    started = _ray(["start", "--head", "--port", str(PORT), "--num-cpus", "1", "--disable-usage-stats"], env)
    assert started.returncode == 0, started.stderr[-2000:]
    try:
        yield f"{ray.util.get_node_ip_address()}:{PORT}", env
    finally:
        _ray(["stop", "--force"], env)


def _bench(address: str, env: dict, out: Path) -> subprocess.CompletedProcess:
    cmd = [sys.executable, "-m", "latent_planner_ros", "bench", "lspp", "--scenes", "1", "--obstacles", "1",
           "--planners", "rrtconnect", "--cluster", address, "--out", str(out)]  # fmt: skip
    return subprocess.run(cmd, env={**env, "PYTHONPATH": str(REPO)}, capture_output=True, text=True, timeout=300)


def test_a_command_with_the_token_runs_on_the_cluster(head, tmp_path):
    address, env = head
    done = _bench(address, env, tmp_path)
    assert done.returncode == 0, done.stderr[-2000:]
    assert json.loads((tmp_path / "lspp.json").read_text())["executor"] == "ray"


def test_a_command_with_another_token_is_refused_with_what_to_check(head, tmp_path):
    address, env = head
    done = _bench(address, {**env, "RAY_AUTH_TOKEN": secrets.token_hex(32)}, tmp_path)
    assert done.returncode == 2
    assert f"could not join the Ray cluster at {address}" in done.stderr and "RAY_AUTH_TOKEN" in done.stderr
    assert "Traceback" not in done.stderr and not (tmp_path / "lspp.json").exists()

"""The launcher run as users run it: a small suite (sim + robot_info) comes up, stops cleanly, and fails loudly.

Plus the argument checks (no process started) and the ROS 2 launch file (compiled only: no `launch` here).
"""

from __future__ import annotations

import ast
import os
import py_compile
import random
import re
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import psutil
import pytest

from latent_planner_ros.launcher import main
from latent_planner_ros.processes.node_suite import LAUNCH_ENV, SuiteError, find_params_file, node_argv, parse_param
from latent_planner_ros.registry import NODES

REPO = Path(__file__).resolve().parents[1]
LAUNCH_FILE = REPO / "launch" / "latent_planner.launch.py"
SMALL_SUITE = ("--nodes", "sim,robot_info", "--scenario", "empty", "--headless")


class Launch:
    """`python -m latent_planner_ros launch ...` as a subprocess on a random domain, its output collected."""

    def __init__(self, *args: str):
        self.domain_id = random.SystemRandom().randint(1, 100)
        env = dict(os.environ, PYTHONUNBUFFERED="1")
        env["PYTHONPATH"] = os.pathsep.join([str(REPO), *filter(None, [os.environ.get("PYTHONPATH")])])
        cmd = [sys.executable, "-m", "latent_planner_ros", "launch", "--domain-id", str(self.domain_id), *args]
        self.proc = subprocess.Popen(
            cmd, cwd=REPO, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True
        )
        self.lines: list[str] = []
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()

    def _read(self) -> None:
        for line in self.proc.stdout:
            self.lines.append(line.rstrip("\n"))

    @property
    def output(self) -> str:
        return "\n".join(self.lines)

    def wait_for_line(self, text: str, timeout_s: float = 40.0) -> bool:
        end = time.monotonic() + timeout_s
        while time.monotonic() < end and self.proc.poll() is None:
            if any(text in line for line in self.lines):
                return True
            time.sleep(0.05)
        return any(text in line for line in self.lines)

    def finish(self, timeout_s: float = 40.0) -> int:
        try:
            code = self.proc.wait(timeout=timeout_s)
        except subprocess.TimeoutExpired:
            os.kill(self.proc.pid, signal.SIGINT)
            self.proc.wait(timeout=30)
            pytest.fail(f"the launcher did not end within {timeout_s} s:\n{self.output}")
        self._reader.join(timeout=5)
        return code

    def pids(self) -> dict[str, int]:
        """Node name -> pid, from the launcher's 'started <name> (pid N)' lines."""
        return {m[1]: int(m[2]) for line in self.lines if (m := re.search(r"started (\w+) \(pid (\d+)\)", line))}

    def leftovers(self) -> list[str]:
        """Processes still alive that the launcher started (by pid, or by the suite's marker variable)."""
        alive = []
        for name, pid in self.pids().items():
            try:
                if psutil.Process(pid).status() != psutil.STATUS_ZOMBIE:
                    alive.append(f"{name} (pid {pid})")
            except psutil.NoSuchProcess:
                pass
        for proc in psutil.process_iter():
            try:
                if proc.environ().get(LAUNCH_ENV) == str(self.proc.pid) and proc.status() != psutil.STATUS_ZOMBIE:
                    alive.append(f"{proc.pid}: {' '.join(proc.cmdline())}")
            except (psutil.NoSuchProcess, psutil.AccessDenied, psutil.ZombieProcess):
                pass
        return alive


@pytest.mark.ros
@pytest.mark.slow
@pytest.mark.timeout(90)
def test_suite_runs_for_duration_and_stops_cleanly():
    launch = Launch(*SMALL_SUITE, "--duration", "3")
    code = launch.finish()
    out = launch.output
    assert code == 0, out
    assert "all 2 nodes are up; running for 3 s" in out, out
    assert re.search(r"^\[sim\] .*scenario 'empty'", out, re.M), out
    assert re.search(r"^\[robot_info\] .*publishing /robot_description", out, re.M), out
    assert "stopped: sim (code 0), robot_info (code 0)" in out, out
    assert set(launch.pids()) == {"sim", "robot_info"}
    assert launch.leftovers() == []


@pytest.mark.ros
@pytest.mark.slow
@pytest.mark.timeout(90)
def test_a_killed_node_stops_the_suite_with_an_error():
    launch = Launch(*SMALL_SUITE)
    try:
        assert launch.wait_for_line("all 2 nodes are up"), launch.output
        os.kill(launch.pids()["robot_info"], signal.SIGKILL)
        code = launch.finish()
    finally:
        if launch.proc.poll() is None:
            launch.proc.send_signal(signal.SIGINT)
            launch.finish()
    assert code == 1, launch.output
    assert "error: node robot_info exited unexpectedly with signal SIGKILL" in launch.output
    assert launch.leftovers() == []


@pytest.mark.ros
@pytest.mark.slow
@pytest.mark.timeout(90)
def test_sigterm_stops_the_suite():
    launch = Launch(*SMALL_SUITE)
    try:
        assert launch.wait_for_line("all 2 nodes are up"), launch.output
        launch.proc.send_signal(signal.SIGTERM)
        code = launch.finish()
    finally:
        if launch.proc.poll() is None:
            launch.proc.kill()
    assert code == 0, launch.output
    assert "SIGTERM: stopping the suite" in launch.output
    assert launch.leftovers() == []


@pytest.mark.ros
@pytest.mark.timeout(90)
def test_a_node_failing_at_startup_is_named():
    launch = Launch(*SMALL_SUITE, "--duration", "30", "--param", "sim:timestep:=5")
    code = launch.finish()
    out = launch.output
    assert code == 1, out
    assert "error: node sim exited with code 2 during start-up" in out, out
    assert re.search(r"^\[sim\] .*cannot start: timestep", out, re.M), out
    assert "all 2 nodes are up" not in out
    assert launch.leftovers() == []


# ---------------------------------------------------------------------- arguments (nothing is started)
@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--nodes", "sim,warp_drive"], "unknown node 'warp_drive'"),
        (["--scenario", "nowhere"], "unknown scenario 'nowhere'"),
        (["--param", "sim:timestep=5"], "expected NODE:NAME:=VALUE"),
        (["--nodes", "sim", "--param", "planner:enabled:=false"], "node 'planner' is not in the suite"),
    ],
)
def test_bad_arguments_are_refused(capsys, args, message):
    assert main(args) == 2
    assert message in capsys.readouterr().err


def test_with_ompl_needs_the_node(capsys):
    if "ompl_planner" in NODES:
        pytest.skip("ompl_planner is registered")
    assert main(["--with-ompl"]) == 2
    assert "ompl_planner node is not available" in capsys.readouterr().err


def test_node_command_line():
    argv = node_argv("sim", ["scenario:=empty"], find_params_file("sim"))
    assert argv[:6] == (sys.executable, "-m", "latent_planner_ros", "run", "sim", "--ros-args")
    assert argv[6:8] == ("--params-file", str(REPO / "config" / "sim.yaml"))
    assert argv[8:] == ("-p", "use_sim_time:=true", "-p", "scenario:=empty")
    assert parse_param("sim:seed:=3") == ("sim", "seed:=3")
    with pytest.raises(SuiteError, match="unknown node"):
        parse_param("nope:seed:=3")


# ---------------------------------------------------------------------- the ROS 2 launch file
def test_launch_file_compiles_and_names_registered_executables(tmp_path):
    py_compile.compile(str(LAUNCH_FILE), cfile=str(tmp_path / "launch.pyc"), doraise=True)
    tree = ast.parse(LAUNCH_FILE.read_text())
    executables = [
        kw.value.value
        for call in ast.walk(tree)
        if isinstance(call, ast.Call)
        for kw in call.keywords
        if kw.arg == "executable" and isinstance(kw.value, ast.Constant)
    ]
    assert executables == ["sim", "scene_encoder", "planner"]
    assert set(executables) <= set(NODES)
    assert "generate_launch_description" in {f.name for f in tree.body if isinstance(f, ast.FunctionDef)}


def test_setup_installs_the_launch_file():
    assert 'glob("launch/*.launch.py")' in (REPO / "setup.py").read_text()


def test_the_consumers_fuse_every_camera_of_the_scenario():
    from latent_planner_ros.launcher import build_suite, parse_args

    def argv_of(*args: str) -> dict[str, tuple[str, ...]]:
        return {s.name: s.argv for s in build_suite(parse_args(list(args))).specs}

    shelf = argv_of("--scenario", "shelf", "--with-ompl")
    topics = "cloud_topics:=[camera/points,shelf_front/points,shelf_side/points]"
    for node in ("scene_encoder", "planner", "ompl_planner"):
        assert topics in shelf[node], node
    assert not any("cloud_topics" in a for a in argv_of("--scenario", "conveyor")["planner"])  # one camera: defaults
    mine = argv_of("--scenario", "shelf", "--param", "planner:cloud_topics:=[camera/points]")["planner"]
    assert mine.index("cloud_topics:=[camera/points]") > mine.index(topics)  # the user's assignment comes last


def test_one_execution_source_at_a_time():
    from latent_planner_ros.launcher import build_suite, parse_args

    def params_of(*args: str) -> dict[str, tuple[str, ...]]:
        return {s.name: s.argv for s in build_suite(parse_args(list(args))).specs}

    default = params_of("--with-ompl")
    assert "enabled:=true" in default["planner"] and "execute:=false" in default["ompl_planner"]
    ompl = params_of("--with-ompl", "--execute", "ompl_planner")
    assert "enabled:=false" in ompl["planner"] and "execute:=true" in ompl["ompl_planner"]
    idle = params_of("--execute", "none")
    assert "enabled:=false" in idle["planner"]
    with pytest.raises(SuiteError, match="one command source at a time"):
        params_of("--with-ompl", "--param", "ompl_planner:execute:=true")
    with pytest.raises(SuiteError, match="not in the suite"):
        params_of("--execute", "ompl_planner")

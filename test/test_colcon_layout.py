"""`colcon build` of the package in a fresh workspace gives the layout `ros2 run` expects.

ROS users build the package with colcon (ament_python); setup.cfg must put the node executables in
lib/latent_planner_ros and setup.py must install package.xml, the ament index marker and the shipped files
(weights, scenario sets, YAMLs) in share/latent_planner_ros, where the installed code finds them without the
source tree (latent_planner_ros/resources.py).
"""

from __future__ import annotations

import json
import os
import random
import shutil
import subprocess
import sys
import sysconfig
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
PACKAGE = "latent_planner_ros"
SOURCES = (
    "setup.py",
    "setup.cfg",
    "package.xml",
    "resource",
    "config",
    "launch",
    PACKAGE,
    "sim_bridge",
    "msg_adapters",
)
BIN = Path(sys.executable).parent  # the venv's bin: colcon and the `python` colcon should use
BUILD_TIMEOUT_S = 300

pytestmark = pytest.mark.slow


def site_packages(prefix: Path) -> Path:
    """<prefix>/lib/pythonX.Y/site-packages, as colcon lays out an install prefix."""
    return prefix / Path(sysconfig.get_path("purelib")).relative_to(sysconfig.get_path("data"))


@pytest.fixture(scope="module")
def install(tmp_path_factory) -> Path:
    """Build a copy of the package sources in a fresh workspace; returns install/latent_planner_ros.

    The workspace's src/ and build/ are removed afterwards, so only the install can serve files.
    """
    colcon = BIN / "colcon"
    if not colcon.exists():
        pytest.skip(f"colcon not installed next to {sys.executable}")
    ws = tmp_path_factory.mktemp("colcon_ws")
    src = ws / "src" / PACKAGE
    src.mkdir(parents=True)
    ignore = shutil.ignore_patterns("__pycache__", "*.pyc", "*.egg-info", ".pytest_cache")
    for name in SOURCES:
        path = REPO / name
        if path.is_dir():
            shutil.copytree(path, src / name, ignore=ignore)
        elif path.exists():
            shutil.copy2(path, src / name)
    env = dict(os.environ, PATH=os.pathsep.join([str(BIN), os.environ.get("PATH", "")]))
    for var in ("AMENT_PREFIX_PATH", "COLCON_PREFIX_PATH", "CMAKE_PREFIX_PATH"):
        env.pop(var, None)
    proc = subprocess.run(
        [str(colcon), "build", "--base-paths", "src"],
        cwd=ws,
        env=env,
        capture_output=True,
        text=True,
        timeout=BUILD_TIMEOUT_S,
    )
    assert proc.returncode == 0, f"colcon build failed:\n{proc.stdout[-5000:]}\n{proc.stderr[-5000:]}"
    shutil.rmtree(ws / "src")
    shutil.rmtree(ws / "build")
    return ws / "install" / PACKAGE


def assert_executable(path: Path) -> None:
    assert path.is_file(), f"missing {path}"
    assert os.access(path, os.X_OK), f"not executable: {path}"


def test_ament_layout(install):
    assert_executable(install / "lib" / PACKAGE / "robot_info")
    assert (install / "share" / PACKAGE / "package.xml").read_text() == (REPO / "package.xml").read_text()
    assert (install / "share" / "ament_index" / "resource_index" / "packages" / PACKAGE).is_file()
    assert (install / "share" / PACKAGE / "launch" / "latent_planner.launch.py").is_file()
    for node in ("sim", "scene_encoder", "planner", "ompl_planner"):
        assert_executable(install / "lib" / PACKAGE / node)
    for pkg in (PACKAGE, "msg_adapters"):
        assert (site_packages(install) / pkg / "__init__.py").is_file(), f"{pkg} not installed"


def test_sim_executable(install):
    if not (REPO / "sim_bridge" / "__init__.py").exists():
        pytest.skip("sim_bridge does not exist (yet) in this checkout")
    assert_executable(install / "lib" / PACKAGE / "sim")
    assert (site_packages(install) / "sim_bridge" / "__init__.py").is_file()


def installed_env(install: Path, ament: bool) -> dict[str, str]:
    """The environment of a process that imports the package from `install` only (PYTHONPATH first), with
    ``$AMENT_PREFIX_PATH`` set to the install prefix (a sourced workspace) or unset."""
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([str(site_packages(install)), *filter(None, [env.get("PYTHONPATH")])])
    env.pop("AMENT_PREFIX_PATH", None)
    if ament:
        env["AMENT_PREFIX_PATH"] = str(install)
    return env


FIND_SHIPPED = """
import json
import latent_planner_ros
from latent_planner_ros import resources
from latent_planner_ros.bench.scenarios import DEFAULT_SET
from latent_planner_ros.models.collision_io import PLANNER_COLLISION, shipped_collision_path
from latent_planner_ros.models.cylinder_classifier import shipped_classifier_path
from latent_planner_ros.models.vae_io import load_vae, shipped_vae_path
from latent_planner_ros.processes.node_suite import find_params_file
from sim_bridge.scenario_files import find_scenario_file

vae, _ = load_vae()
print(json.dumps({
    "module": latent_planner_ros.__file__,
    "ament_share": str(resources.ament_share_dir()),
    "vae": str(shipped_vae_path().with_suffix(".safetensors")),
    "collision": str(shipped_collision_path().with_suffix(".safetensors")),
    "collision_planner": str(shipped_collision_path(PLANNER_COLLISION).with_suffix(".safetensors")),
    "lspp": str(shipped_classifier_path().with_suffix(".safetensors")),
    "scenario_set": str(DEFAULT_SET),
    "planner_yaml": str(find_params_file("planner")),
    "conveyor_yaml": str(find_scenario_file("conveyor")),
}))
"""
"""Prints where the installed code finds each shipped file (JSON), after loading the shipped VAE."""


@pytest.mark.parametrize("ament", [True, False], ids=["sourced", "not_sourced"])
def test_installed_package_finds_shipped_files(install, ament):
    """Without a source tree, the weights, the scenario set and the YAMLs come from the install's share/;
    through the ament index when the workspace is sourced, from the install prefix of the code otherwise."""
    proc = subprocess.run(
        [sys.executable, "-c", FIND_SHIPPED],
        cwd=install.parent.parent,
        env=installed_env(install, ament),
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert proc.returncode == 0, f"{proc.stdout}\n{proc.stderr}"
    found = json.loads(proc.stdout.strip().splitlines()[-1])
    assert Path(found.pop("module")).is_relative_to(site_packages(install))
    share = install / "share" / PACKAGE
    assert found.pop("ament_share") == (str(share) if ament else "None")
    for what, path in found.items():
        assert Path(path).is_relative_to(share), f"{what}: {path} is not in {share}"
        assert Path(path).is_file(), f"{what}: {path} missing"


def test_installed_robot_info_runs(install):
    """Run the installed executable as `ros2 run` would after sourcing the workspace."""
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([str(site_packages(install)), *filter(None, [env.get("PYTHONPATH")])])
    env["ROS_DOMAIN_ID"] = str(random.SystemRandom().randint(1, 100))
    outside = install.parent.parent  # the workspace: not the repository, so imports must come from install/
    probe = subprocess.run(
        [sys.executable, "-c", "import latent_planner_ros, msg_adapters; print(latent_planner_ros.__file__)"],
        cwd=outside,
        env=env,
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert probe.returncode == 0, probe.stderr
    assert Path(probe.stdout.strip()).is_relative_to(install), f"imported {probe.stdout.strip()}, not the install"

    proc = subprocess.run(
        [str(install / "lib" / PACKAGE / "robot_info"), "--once"],
        cwd=outside,
        env=env,
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert proc.returncode == 0, f"{proc.stdout}\n{proc.stderr}"
    assert "Traceback" not in proc.stderr

"""package.xml is a valid format-3 manifest that declares every ROS 2 package (and rosdep-keyed library) the code
imports, and no ROS 2 package it does not."""

from __future__ import annotations

import ast
import re
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
SOURCE_DIRS = ("latent_planner_ros", "sim_bridge", "msg_adapters", "launch")
ROS_PACKAGES = {"rclpy", "launch", "launch_ros", "ament_index_python"}
"""ROS 2 packages imported by name; interface packages are recognised by their suffix (ROS_SUFFIXES)."""
ROS_SUFFIXES = ("_msgs", "_srvs", "_interfaces")
ROSDEP_KEYS = {
    "numpy": "python3-numpy",
    "scipy": "python3-scipy",
    "yaml": "python3-yaml",
    "matplotlib": "python3-matplotlib",
    "tqdm": "python3-tqdm",
    "imageio": "python3-imageio",
    "open3d": "python3-open3d-pip",
    "hypothesis": "python3-hypothesis",
    "trimesh": "python3-trimesh-pip",
    "selenium": "python3-selenium",
}
"""Imported module -> its rosdep key, for the libraries package.xml declares as rosdep keys."""
REQUIREMENT_MODULES = {"pyyaml": "yaml", "pin": "pinocchio"}
"""requirements.txt name -> imported module, where they differ."""
TOOLING = ("ros-jazzy-", "setuptools", "colcon-", "pytest", "ruff", "import-linter", "mypy", "types-", "scipy-stubs")
"""requirements.txt entries that are ROS itself (pip wheels) or build and test tools, not runtime libraries."""


def imported_modules() -> set[str]:
    """Top-level names of every absolute import in the package's Python sources."""
    names: set[str] = set()
    for d in SOURCE_DIRS:
        for path in (REPO / d).rglob("*.py"):
            for node in ast.walk(ast.parse(path.read_text(), filename=str(path))):
                if isinstance(node, ast.Import):
                    names.update(alias.name.split(".")[0] for alias in node.names)
                elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
                    names.add(node.module.split(".")[0])
    return names


def is_ros_package(name: str) -> bool:
    return name in ROS_PACKAGES or name.endswith(ROS_SUFFIXES)


@pytest.fixture(scope="module")
def manifest() -> ET.Element:
    root = ET.parse(REPO / "package.xml").getroot()
    assert root.tag == "package" and root.get("format") == "3"
    assert root.findtext("name") == "latent_planner_ros"
    assert root.findtext("export/build_type") == "ament_python"
    return root


def exec_depends(root: ET.Element) -> set[str]:
    return {(e.text or "").strip() for tag in ("exec_depend", "depend") for e in root.findall(tag)}


def test_catkin_pkg_accepts_the_manifest():
    """colcon reads package.xml through catkin_pkg; its validation must pass."""
    package = pytest.importorskip("catkin_pkg.package")
    pkg = package.parse_package(REPO / "package.xml")
    pkg.validate()
    assert pkg.package_format == 3


def test_every_imported_ros_package_is_an_exec_depend(manifest):
    imported = {name for name in imported_modules() if is_ros_package(name)}
    assert {"rclpy", "sensor_msgs", "std_srvs"} <= imported  # the scan sees the node code
    missing = imported - exec_depends(manifest)
    assert not missing, f"imported but not in package.xml: {sorted(missing)}"


def test_no_ros_exec_depend_without_an_import(manifest):
    declared = {name for name in exec_depends(manifest) if not name.startswith("python3-")}
    unused = declared - imported_modules()
    assert not unused, f"in package.xml but imported nowhere: {sorted(unused)}"


def test_rosdep_keyed_libraries_are_declared(manifest):
    imported = imported_modules()
    missing = {key for module, key in ROSDEP_KEYS.items() if module in imported} - exec_depends(manifest)
    assert not missing, f"imported libraries without their rosdep key in package.xml: {sorted(missing)}"


def test_every_pip_requirement_is_a_rosdep_key_or_named_in_the_manifest(manifest):
    """A runtime library of requirements.txt is declared by its rosdep key, or package.xml says why not."""
    names = [line.split("==")[0].split("[")[0].strip() for line in (REPO / "requirements.txt").read_text().splitlines()]
    runtime = [n for n in names if n and not n.startswith("#") and not n.startswith(TOOLING)]
    assert {"torch", "ruckig", "numpy"} <= set(runtime)
    comments = " ".join(re.findall(r"<!--(.*?)-->", (REPO / "package.xml").read_text(), re.S))
    declared = exec_depends(manifest) | {(e.text or "").strip() for e in manifest.findall("test_depend")}
    for name in runtime:
        key = ROSDEP_KEYS.get(REQUIREMENT_MODULES.get(name, name))
        assert (key in declared) if key else (name in comments), f"{name}: neither its rosdep key nor a reason"

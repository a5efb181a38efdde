"""Shipped files are found in the source tree, else in an install's share/latent_planner_ros (ament index first)."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from latent_planner_ros import resources
from latent_planner_ros.bench.scenarios import DEFAULT_SET
from latent_planner_ros.models.collision_io import PLANNER_COLLISION, shipped_collision_path
from latent_planner_ros.models.cylinder_classifier import shipped_classifier_path
from latent_planner_ros.models.vae_io import shipped_vae_path
from latent_planner_ros.processes.node_suite import find_params_file
from sim_bridge.scenario_files import find_scenario_file

REPO = Path(__file__).resolve().parents[1]


def fake_install(prefix: Path, register: bool = True) -> Path:
    """An install prefix holding share/latent_planner_ros/checkpoints/vae_kinematic.{safetensors,json} (empty
    files) and, with `register`, the ament index marker; returns its share/latent_planner_ros."""
    share = prefix / "share" / resources.PACKAGE
    (share / "checkpoints").mkdir(parents=True)
    for suffix in (".safetensors", ".json"):
        (share / "checkpoints" / f"vae_kinematic{suffix}").touch()
    if register:
        marker = prefix / "share" / "ament_index" / "resource_index" / "packages" / resources.PACKAGE
        marker.parent.mkdir(parents=True)
        marker.touch()
    return share


@pytest.fixture
def no_source_checkpoints(tmp_path, monkeypatch) -> None:
    """The source tree's checkpoints directory replaced by an empty one, as in an installed package."""
    empty = tmp_path / "package" / "checkpoints"
    empty.mkdir(parents=True)
    monkeypatch.setitem(resources.SOURCE_DIRS, "checkpoints", empty)


def test_checkout_finds_its_own_files():
    for stem in (shipped_vae_path(), shipped_collision_path(PLANNER_COLLISION), shipped_classifier_path()):
        assert stem.parent == REPO / "latent_planner_ros" / "checkpoints"
        assert stem.with_suffix(".safetensors").is_file() and stem.with_suffix(".json").is_file()
    assert DEFAULT_SET == REPO / "latent_planner_ros" / "bench" / "scenarios" / "tabletop_heldout_100.json"
    assert DEFAULT_SET.is_file()
    assert find_params_file("planner") == REPO / "config" / "planner.yaml"
    assert find_scenario_file("conveyor") == REPO / "config" / "scenarios" / "conveyor.yaml"


def test_source_tree_wins_over_a_registered_install(tmp_path, monkeypatch):
    fake_install(tmp_path / "prefix")
    monkeypatch.setenv("AMENT_PREFIX_PATH", str(tmp_path / "prefix"))
    assert shipped_vae_path().parent == REPO / "latent_planner_ros" / "checkpoints"


def test_installed_package_reads_the_ament_share_directory(tmp_path, monkeypatch, no_source_checkpoints):
    share = fake_install(tmp_path / "prefix")
    monkeypatch.setenv("AMENT_PREFIX_PATH", os.pathsep.join([str(tmp_path / "elsewhere"), str(tmp_path / "prefix")]))
    assert resources.ament_share_dir() == share
    assert resources.share_dirs()[0] == share
    assert shipped_vae_path() == share / "checkpoints" / "vae_kinematic"


def test_unregistered_prefix_is_not_read_through_the_index(tmp_path, monkeypatch, no_source_checkpoints):
    fake_install(tmp_path / "prefix", register=False)
    monkeypatch.setenv("AMENT_PREFIX_PATH", str(tmp_path / "prefix"))
    assert resources.ament_share_dir() is None
    monkeypatch.delenv("AMENT_PREFIX_PATH")
    assert resources.ament_share_dir() is None


def test_missing_file_names_the_source_tree_path(no_source_checkpoints, monkeypatch):
    monkeypatch.delenv("AMENT_PREFIX_PATH", raising=False)
    assert shipped_vae_path("no_such_model") == resources.SOURCE_DIRS["checkpoints"] / "no_such_model"
    with pytest.raises(KeyError):
        resources.resource_dirs("no_such_directory")


def test_resources_module_imports_no_ros():
    code = (
        "import sys; import latent_planner_ros.resources as r; r.share_dirs(); "
        "print(sorted(m for m in sys.modules if m.split('.')[0] in ('rclpy', 'launch', 'launch_ros')))"
    )
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60, cwd=REPO)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.strip() == "[]"

"""The command-line entry point dispatches to the registered commands and refuses unknown ones."""

import importlib
import subprocess
import sys

from latent_planner_ros.cli import main
from latent_planner_ros.registry import BENCH, NODES, TRAIN


def test_info_prints_the_robot(capsys):
    assert main(["info"]) == 0
    assert "panda_joint7" in capsys.readouterr().out


def test_unknown_names_are_refused():
    for argv in (["bench", "nope", "--out", "x"], ["train", "nope"], ["run", "nope"]):
        proc = subprocess.run([sys.executable, "-m", "latent_planner_ros", *argv], capture_output=True, text=True)
        assert proc.returncode == 2 and "invalid choice" in proc.stderr


def test_registered_targets_import_and_are_callable():
    for table in (NODES, TRAIN, BENCH):
        for target in table.values():
            module, func = target.split(":")
            assert callable(getattr(importlib.import_module(module), func)), target


def test_every_command_has_help():
    for argv in (["bench", "planner", "--help"], ["train", "vae", "--help"], ["launch", "--help"]):
        proc = subprocess.run([sys.executable, "-m", "latent_planner_ros", *argv], capture_output=True, text=True)
        assert proc.returncode == 0 and "usage" in proc.stdout.lower(), (argv, proc.stderr[-500:])


def test_console_script_is_installed():
    bin_dir = __import__("pathlib").Path(sys.executable).parent
    assert (bin_dir / "latent-planner").exists()

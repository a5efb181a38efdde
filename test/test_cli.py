"""The command-line entry point dispatches to the registered commands and refuses unknown ones."""

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


def test_registered_targets_name_modules_and_functions():
    for table in (NODES, TRAIN, BENCH):
        for target in table.values():
            module, func = target.split(":")
            assert module and func.isidentifier()


def test_console_script_is_installed():
    bin_dir = __import__("pathlib").Path(sys.executable).parent
    assert (bin_dir / "latent-planner").exists()

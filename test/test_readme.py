"""Every command in the README is run: `make` targets by CI (.ci/run), the others here."""

import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent


def readme_commands() -> list[str]:
    blocks = re.findall(r"```bash\n(.*?)```", (ROOT / "README.md").read_text(), flags=re.S)
    lines = [line.split("#", 1)[0].strip() for block in blocks for line in block.splitlines()]
    return [line for line in lines if line]


def test_make_targets_in_the_readme_are_run_by_ci():
    ci = (ROOT / ".ci" / "run").read_text()
    makes = [c for c in readme_commands() if c.startswith("make ")]
    assert {"make demo", "make test"} <= set(makes)
    for cmd in makes:
        assert re.search(rf"^{re.escape(cmd)}$", ci, flags=re.M), f"{cmd!r} is in the README but not in .ci/run"


def test_every_readme_command_is_known():
    for cmd in readme_commands():
        assert cmd.startswith(("make ", ".venv/bin/python -m latent_planner_ros ")), cmd


@pytest.mark.slow
@pytest.mark.parametrize("cmd", [c for c in readme_commands() if c.startswith(".venv/bin/python")])
def test_readme_python_commands_run(cmd, tmp_path):
    args = shlex.split(cmd)[1:]
    args = [str(tmp_path) if a == "bench_out" else a for a in args]
    proc = subprocess.run([sys.executable, *args], cwd=ROOT, capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr[-2000:]
    if "bench" in args:
        suite = args[args.index("bench") + 1]
        assert (tmp_path / f"{suite}.json").is_file() and (tmp_path / f"{suite}.md").is_file()
        assert list(tmp_path.glob(f"{suite}_*.png"))

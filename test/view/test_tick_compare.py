"""test/view/tick_compare.py: pooled tick percentiles of two groups of demo runs and their difference."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import tick_compare  # noqa: E402


def _run(path: Path, ticks: np.ndarray) -> str:
    path.mkdir()
    np.savez(path / "trial.npz", tick_ms=ticks)
    return str(path)


def test_difference_of_pooled_percentiles(tmp_path, capsys):
    rng = np.random.default_rng(1)
    a = [_run(tmp_path / f"a{i}", np.r_[np.nan, rng.uniform(5.0, 10.0, 300)]) for i in range(3)]
    b = [_run(tmp_path / f"b{i}", np.r_[np.nan, rng.uniform(5.0, 10.0, 300) + 3.0]) for i in range(3)]
    assert tick_compare.main(a + ["--"] + b) == 0
    out = capsys.readouterr().out
    assert "A: 3 runs, 900 ticks" in out  # the NaN of each run (before its first tick) is left out
    line = next(x for x in out.splitlines() if x.startswith("p50 B - A"))
    assert 2.5 < float(line.split(":")[1].split("ms")[0]) < 3.5


def test_usage_without_separator(capsys):
    assert tick_compare.main(["only_one_group"]) == 2
    assert "tick_compare.py DIR_A" in capsys.readouterr().out

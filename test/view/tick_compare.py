"""Compare the planner's tick times of two groups of demo runs (e.g. without and with the view).

    .venv/bin/python test/view/tick_compare.py DIR_A [DIR_A ...] -- DIR_B [DIR_B ...]

Each DIR is a demo's `--out` (its `trial.npz` holds the planner's tick time per status message). The ticks of
each group are pooled; printed: ticks, p50 and p99 [ms] per group, and the p50 and p99 differences (B - A) with
95 % bootstrap intervals (the runs resampled within each group, 2,000 rounds). docs/benchmark.md quotes it.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np


def _runs(dirs: list[str]) -> list[np.ndarray]:
    ticks = [np.asarray(np.load(Path(d) / "trial.npz")["tick_ms"], dtype=float) for d in dirs]
    return [t[np.isfinite(t)] for t in ticks]  # status messages before the first tick have none


def _pooled(runs: list[np.ndarray], q: float) -> float:
    return float(np.percentile(np.concatenate(runs), q))


def main(argv: list[str]) -> int:
    if "--" not in argv:
        print(__doc__)
        return 2
    cut = argv.index("--")
    a, b = _runs(argv[:cut]), _runs(argv[cut + 1 :])
    rng = np.random.default_rng(0)
    for name, runs in (("A", a), ("B", b)):
        ticks = np.concatenate(runs)
        p50, p99 = _pooled(runs, 50), _pooled(runs, 99)
        print(f"{name}: {len(runs)} runs, {len(ticks)} ticks, p50 {p50:.1f} ms, p99 {p99:.1f} ms")
    for q in (50, 99):
        diffs = []
        for _ in range(2000):
            ra = [a[i] for i in rng.integers(0, len(a), len(a))]
            rb = [b[i] for i in rng.integers(0, len(b), len(b))]
            diffs.append(_pooled(rb, q) - _pooled(ra, q))
        lo, hi = np.percentile(diffs, [2.5, 97.5])
        print(f"p{q} B - A: {_pooled(b, q) - _pooled(a, q):+.1f} ms (95 % interval {lo:+.1f} .. {hi:+.1f} ms)")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))

"""Small statistics for benchmark reports."""

from __future__ import annotations

import numpy as np


def wilson_ci95(k: int, n: int) -> tuple[float, float]:
    """Wilson score interval of a success rate k/n (95 %)."""
    if n == 0:
        return 0.0, 1.0
    z, p = 1.96, k / n
    centre = (p + z * z / (2 * n)) / (1 + z * z / n)
    half = z * np.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / (1 + z * z / n)
    # the interval holds p itself (rounding can leave centre + half a hair below 1 at k = n)
    return float(min(p, max(0.0, centre - half))), float(max(p, min(1.0, centre + half)))


def percentile(values, q: float) -> float | None:
    """The q-th percentile (0..100) of the finite values, or None when there are none."""
    a = np.asarray(values, dtype=float)
    a = a[np.isfinite(a)]
    return float(np.percentile(a, q)) if a.size else None

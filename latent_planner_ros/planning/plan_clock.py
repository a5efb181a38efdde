"""Where a plan's time goes: exclusive wall-clock sections (a nested section's time counts only for itself).

clock = PlanClock()
with clock.section("steps"):
    ...
    with clock.section("check"):    # counted as check, not as steps
        ...
clock.totals()                      # {"steps_s": ..., "check_s": ...}
"""

from __future__ import annotations

import time
from collections import Counter, defaultdict
from collections.abc import Callable
from contextlib import contextmanager


class PlanClock:
    """Accumulates wall time [s] per named section; time inside a nested section is taken from its parent.

    Args:
        now: the clock [s] (default: time.perf_counter).
    """

    def __init__(self, now: Callable[[], float] = time.perf_counter) -> None:
        self._now = now
        self.seconds: defaultdict[str, float] = defaultdict(float)
        self.counts: Counter[str] = Counter()
        self._stack: list[str] = []
        self._since = 0.0

    def reset(self) -> None:
        self.seconds.clear()
        self.counts.clear()
        self._stack.clear()

    @contextmanager
    def section(self, name: str):
        now = self._now()
        if self._stack:
            self.seconds[self._stack[-1]] += now - self._since
        self._stack.append(name)
        self._since = now
        try:
            yield
        finally:
            now = self._now()
            self.seconds[self._stack.pop()] += now - self._since
            self._since = now

    def totals(self) -> dict[str, float]:
        """{section + "_s": seconds}."""
        return {f"{k}_s": float(v) for k, v in self.seconds.items()}

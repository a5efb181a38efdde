"""Slow rebuilds on a worker thread, taken up by the control loop between two ticks. No ROS.

A node whose parameter change needs new objects (planners, backends, their warm-up: ~0.3-0.7 s) validates the
change at once, in the set-parameters callback (a bad value is refused there), hands the build to a
RebuildWorker, and at the start of each tick asks `take()` for a finished build to swap in. Only the newest
request matters: one submitted while another builds supersedes it, and a finished build that a newer request
has made obsolete is never handed out.
"""

from __future__ import annotations

import os
import threading
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

NICE = 10
"""Niceness of the worker thread (Linux threads have their own): the loop keeps the CPU when it is scarce."""


@dataclass(frozen=True)
class Built:
    """A finished build: the request it was made from and the `build` function's result, or the error it raised
    (result None)."""

    request: Any
    result: Any
    error: BaseException | None = None


class RebuildWorker:
    """Runs `build(request)` on a daemon thread for the newest submitted request.

    Args:
        build: makes the new objects from a request; may raise (the error is handed out by `take`).
        name: the thread's name.
    """

    def __init__(self, build: Callable[[Any], Any], name: str = "rebuild"):
        self._build = build
        self._cond = threading.Condition()
        self._wanted: tuple[int, Any] | None = None  # (generation, request) not yet started
        self._generation = 0  # of the newest submitted request
        self._done: tuple[int, Built] | None = None
        self._busy = False  # a build runs
        self._closed = False
        self._thread = threading.Thread(target=self._run, name=name, daemon=True)
        self._thread.start()

    @property
    def pending(self) -> bool:
        """A submitted request has not been taken yet (waiting, building, or built)."""
        with self._cond:
            return self._wanted is not None or self._busy or self._done is not None

    def submit(self, request: Any) -> None:
        """Build `request` next; any older request, waiting or building, will not be handed out."""
        with self._cond:
            self._generation += 1
            self._wanted = (self._generation, request)
            self._done = None
            self._cond.notify()

    def take(self) -> Built | None:
        """The build of the newest request once it is finished (once), else None. Never blocks."""
        with self._cond:
            if self._done is None or self._done[0] != self._generation:
                return None
            done, self._done = self._done[1], None
            return done

    def close(self) -> None:
        """Stop the thread after the build it runs, if any."""
        with self._cond:
            self._closed = True
            self._cond.notify()

    def _run(self) -> None:
        try:  # Linux: a nicer thread, so a busy CPU runs the control loop first (its builds may take longer)
            os.setpriority(os.PRIO_PROCESS, threading.get_native_id(), NICE)
        except (AttributeError, OSError):
            pass
        while True:
            with self._cond:
                while self._wanted is None and not self._closed:
                    self._cond.wait()
                if self._closed:
                    return
                (generation, request), self._wanted = self._wanted, None
                self._busy = True
            try:
                built = Built(request, self._build(request))
            except Exception as err:  # handed to the loop, which logs it and keeps the old objects
                built = Built(request, None, err)
            with self._cond:
                self._busy = False
                if generation == self._generation:
                    self._done = (generation, built)

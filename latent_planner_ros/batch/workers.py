"""Worker processes of the benches: they end with the bench process that started them.

A process pool's workers wait on its task queue; when the bench process is killed (SIGTERM or SIGKILL from
outside, not Ctrl-C, which reaches the whole process group) they would wait forever, each holding its models
in memory. `exit_with_parent` (a pool initializer, or called from one) makes a worker exit within about a
second of its parent's death.
"""

from __future__ import annotations

import os
import threading
import time

POLL_S = 0.5
"""how often [s] a worker checks that its parent is still there"""


def exit_with_parent() -> None:
    """In a worker process: exit (status 1) as soon as the process that started it is gone."""
    parent = os.getppid()

    def watch() -> None:
        while os.getppid() == parent:
            time.sleep(POLL_S)
        os._exit(1)

    threading.Thread(target=watch, name="exit-with-parent", daemon=True).start()

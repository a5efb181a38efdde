"""Memory, open files and threads of a process group, read from /proc (Linux). No ROS.

A node of the suite runs in a process group of its own (processes/supervisor.py), whose id is the node's pid;
anything it starts stays in that group, so the group's sums are the node's footprint.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

PROC = Path("/proc")


@dataclass(frozen=True)
class Usage:
    """rss_mb: resident memory [MB] (VmRSS, MiB); fds: open file descriptors; threads; processes counted."""

    rss_mb: float
    fds: int
    threads: int
    processes: int


def group_pids(pgid: int, proc: Path = PROC) -> list[int]:
    """The pids of the processes whose process group is `pgid`."""
    pids = []
    for entry in proc.iterdir():
        if not entry.name.isdigit():
            continue
        try:
            stat = (entry / "stat").read_text()
        except OSError:
            continue
        fields = stat[stat.rindex(")") + 2 :].split()  # after "pid (comm) ": state ppid pgrp ...
        if len(fields) > 2 and int(fields[2]) == pgid:
            pids.append(int(entry.name))
    return sorted(pids)


def process_usage(pid: int, proc: Path = PROC) -> Usage | None:
    """One process's usage, or None if it has gone."""
    try:
        status = (proc / str(pid) / "status").read_text()
        fds = len(os.listdir(proc / str(pid) / "fd"))
    except (OSError, ValueError):
        return None
    values = {}
    for line in status.splitlines():
        key, _, rest = line.partition(":")
        if key in ("VmRSS", "Threads"):
            values[key] = int(rest.split()[0])
    return Usage(values.get("VmRSS", 0) / 1024.0, fds, values.get("Threads", 0), 1)


def group_usage(pgid: int, proc: Path = PROC) -> Usage | None:
    """The summed usage of process group `pgid`, or None when none of its processes is left."""
    usages = [u for u in (process_usage(p, proc) for p in group_pids(pgid, proc)) if u is not None]
    if not usages:
        return None
    return Usage(sum(u.rss_mb for u in usages), sum(u.fds for u in usages), sum(u.threads for u in usages), len(usages))

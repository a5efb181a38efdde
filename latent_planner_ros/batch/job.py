"""A batch job and its executor's configuration, and how a worker runs one task of a job.

Shared by the local executor (batch/executor.py) and its Ray path (batch/ray_cluster.py), which both run
`run_task` in their worker processes.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any


class ClusterError(RuntimeError):
    """--cluster cannot be used: Ray is not installed, or the cluster at the address cannot be joined (the message
    says what to check). The commands print it as one line (cli.py)."""


@dataclass(frozen=True)
class ExecutorConfig:
    """Which executor runs a batch job, and how wide."""

    workers: int = 2
    """local processes (1 = in this process), or the CPUs of a Ray cluster started with cluster="auto"
    (0 = every CPU of this machine); ignored for a running cluster, whose CPUs decide"""
    cluster: str = ""
    """empty = local processes; "auto" = start a local Ray cluster for the job; else the address (HOST:PORT) of a
    running Ray cluster"""
    retries: int = 3
    """Ray: times a task is run again by Ray when its worker process or node dies (Ray's max_retries)"""
    resubmits: int = 2
    """Ray: times the driver submits a task again when Ray gives it up as lost after its retries"""

    def __post_init__(self):
        if self.workers < 0 or self.retries < 0 or self.resubmits < 0:
            raise ValueError("workers, retries and resubmits must be >= 0")

    @property
    def name(self) -> str:
        """The reports' "executor" field: "ray" or "processes"."""
        return "ray" if self.cluster else "processes"


@dataclass(frozen=True)
class Job:
    """A batch job: `fn(state, *task)` for every task, with state = `setup(*setup_args)` built once per worker
    process (`fn(*task)` when setup is None). fn and setup are module-level functions (pickled by name)."""

    fn: Callable
    setup: Callable | None = None
    setup_args: tuple = ()


_STATE: dict[str, Any] = {}
"""per worker process: the state of the job it last ran, under that job's key (one job's state at a time)"""


def run_task(key: str, job: Job, task: tuple) -> Any:
    """In a worker: one task of `job` (whose state is built on the worker's first task of the job `key`)."""
    if job.setup is None:
        return job.fn(*task)
    if key not in _STATE:
        _STATE.clear()  # a worker that ran an earlier job drops its state first
        _STATE[key] = job.setup(*job.setup_args)
    return job.fn(_STATE[key], *task)


def drop_state(key: str) -> None:
    """Forget the state of the job `key` in this process (after the job ran here, in the caller's process)."""
    _STATE.pop(key, None)

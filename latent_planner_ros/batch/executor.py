"""Where the batch work runs: local worker processes (the default) or a Ray cluster.

A batch job is a list of independent tasks (one problem, one scenario set, one shard, one scene), each a tuple of
arguments to a module-level function. Every task carries its own seeds, so a result does not depend on which
worker ran it nor in what order: `Executor.map` yields `(task index, result)` in completion order and the
caller assembles the results by index (progress bars advance per result, as before).

    with Executor(ExecutorConfig(workers=2)) as ex:                   # spawned local processes
    with Executor(ExecutorConfig(workers=2, cluster="auto")) as ex:   # a local Ray cluster of 2 CPUs
    with Executor(ExecutorConfig(cluster="10.0.0.5:6379")) as ex:     # a running Ray cluster
        for i, result in ex.map(Job(fn, setup, setup_args), tasks): ...

A job's state (its planners, its networks) is built once per worker process by `setup(*setup_args)` and handed to
every task that worker runs: `fn(state, *task)` (`fn(*task)` without a setup). One worker (and no cluster) runs the
tasks in this process. Ray (batch/ray_cluster.py) is imported only on the Ray path; a task whose worker died is
run again (see ExecutorConfig.retries and .resubmits).
"""

from __future__ import annotations

import argparse
import os
import uuid
from collections.abc import Iterator, Sequence
from typing import Any

from latent_planner_ros.batch.job import ExecutorConfig, Job, drop_state, run_task
from latent_planner_ros.batch.workers import exit_with_parent

__all__ = ["Executor", "ExecutorConfig", "Job", "add_executor_args", "executor_config", "run_task"]


class Executor:
    """Runs batch jobs on local processes or a Ray cluster (a context manager: a Ray connection, and a cluster
    started for it, last until exit)."""

    def __init__(self, config: ExecutorConfig | None = None):
        self.config = config or ExecutorConfig()
        self._ray = None  # batch/ray_cluster.RayConnection once connected

    @property
    def name(self) -> str:
        return self.config.name

    def __enter__(self) -> Executor:
        if self.config.cluster:
            self._connect()
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def close(self) -> None:
        """Disconnect from Ray (and stop a cluster started for this executor); nothing for processes."""
        if self._ray is not None:
            self._ray.close()
            self._ray = None

    def _connect(self):
        if self._ray is None:
            from latent_planner_ros.batch.ray_cluster import RayConnection

            self._ray = RayConnection(self.config)
        return self._ray

    def map(self, job: Job, tasks: Sequence[tuple]) -> Iterator[tuple[int, Any]]:
        """(index into tasks, result) of every task, in completion order; an exception raised by a task is raised
        here (the tasks not yet done are dropped)."""
        key = uuid.uuid4().hex
        if self.config.cluster:
            yield from self._connect().map(key, job, list(tasks))
        elif self.config.workers <= 1 or len(tasks) <= 1:
            try:
                for i, task in enumerate(tasks):
                    yield i, run_task(key, job, task)
            finally:
                drop_state(key)
        else:
            yield from _process_map(key, job, list(tasks), self.config.workers)


THREAD_VARIABLES = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")
"""thread-pool sizes of the native libraries, 1 in each worker process unless the environment sets them (as Ray
does for a task of one CPU); a job that wants more torch threads sets them itself (torch.set_num_threads)"""


def _init_process_worker() -> None:
    """Pool initializer: runs before the worker imports numpy or torch (this module imports neither), so the
    native libraries start with one thread each; two workers with a BLAS pool of two threads each overloaded two
    cores (bench table --scenes 20: 70 s vs 40 s)."""
    for name in THREAD_VARIABLES:
        os.environ.setdefault(name, "1")
    exit_with_parent()


def _process_map(key: str, job: Job, tasks: list[tuple], workers: int) -> Iterator[tuple[int, Any]]:
    import multiprocessing as mp
    from concurrent.futures import ProcessPoolExecutor, as_completed

    ctx = mp.get_context("spawn")
    with ProcessPoolExecutor(min(workers, len(tasks)), ctx, initializer=_init_process_worker) as pool:
        futures = {pool.submit(run_task, key, job, t): i for i, t in enumerate(tasks)}
        try:
            for f in as_completed(futures):
                yield futures[f], f.result()
        finally:
            for f in futures:
                f.cancel()


def add_executor_args(parser: argparse.ArgumentParser, workers: int | None = None) -> None:
    """--cluster (and --workers with default `workers`, unless None: the parser has its own)."""
    if workers is not None:
        parser.add_argument(
            "--workers", type=int, default=workers, help=f"processes, or CPUs of --cluster auto (default {workers})"
        )
    parser.add_argument(
        "--cluster",
        default="",
        metavar="auto|ADDRESS",
        help="run the tasks on Ray (pip install .[cluster]): 'auto' starts a local cluster of --workers CPUs, "
        "ADDRESS (HOST:PORT) joins a running one (docs/cluster.md); default: local processes",
    )


def executor_config(args: argparse.Namespace) -> ExecutorConfig:
    """The ExecutorConfig of parsed --workers / --cluster."""
    return ExecutorConfig(workers=max(0, getattr(args, "workers", 1)), cluster=args.cluster.strip())

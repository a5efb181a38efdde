"""The Ray path of batch/executor.py: tasks as Ray tasks, one CPU each, on a local or a running cluster.

Imported only when a command is given --cluster; Ray is the optional extra `pip install .[cluster]`
(requirements-cluster.txt). Each task runs `job.run_task` in a Ray worker process (`run_pickled`); Ray
reuses worker processes, so a job's state is built once per worker as with local processes. A task whose worker
process (or node) dies is run again by Ray (`max_retries`); one that Ray still gives up as lost is submitted again
by the driver (ExecutorConfig.resubmits), so a lost worker costs time, not results. An exception raised by the
task itself is not retried: it is raised in the driver.
"""

from __future__ import annotations

import os
import pickle
import sys
from collections.abc import Iterator
from typing import Any

from latent_planner_ros.batch.job import ClusterError, ExecutorConfig, Job, run_task


def run_pickled(key: str, job: Job, task: bytes) -> bytes:
    """`run_task` on a pickled task, its result pickled: arguments and results are private, writable copies on
    both sides, as through a process pool (Ray hands out numpy arrays as read-only views of its object store)."""
    return pickle.dumps(run_task(key, job, pickle.loads(task)), protocol=pickle.HIGHEST_PROTOCOL)


INSTALL_HINT = "Ray is not installed: pip install .[cluster] (or: pip install -r requirements-cluster.txt)"


class MissingRay(ClusterError, ImportError):
    """--cluster without the optional extra."""


JOIN_HINT = (
    "is a Ray head running there (`ray start --head --port PORT` prints the address to use, not 127.0.0.1), and "
    "do this shell and every machine of the cluster export the same RAY_AUTH_MODE and RAY_AUTH_TOKEN "
    "(docs/cluster.md)?"
)


def import_ray():
    """The ray module, or ClusterError (an ImportError too) naming the extra to install."""
    try:
        import ray
    except ImportError as err:
        raise MissingRay(f"--cluster needs {INSTALL_HINT}") from err
    return ray


def _lost_errors(ray) -> tuple[type[BaseException], ...]:
    """Ray's errors for a task lost to a failure of the system (not raised by the task itself)."""
    e = ray.exceptions
    return (e.WorkerCrashedError, e.NodeDiedError, e.ObjectLostError, e.OwnerDiedError, e.LocalRayletDiedError)


class RayConnection:
    """A connection of this process to a Ray cluster: `cluster="auto"` starts a local one of `workers` CPUs (all
    of this machine's for 0) that stops with the connection; an address joins a running one. A process already
    connected (ray.init called before) keeps its connection, which this object neither replaces nor closes."""

    def __init__(self, config: ExecutorConfig):
        self.config = config
        self.ray = ray = import_ray()
        self.owned = not ray.is_initialized()
        if self.owned:
            if config.cluster == "auto":
                cpus = config.workers or os.cpu_count() or 1
                ray.init(address="local", num_cpus=cpus, include_dashboard=False, configure_logging=False)
            else:
                try:
                    ray.init(address=config.cluster, configure_logging=False)
                except (ConnectionError, ray.exceptions.AuthenticationError) as err:
                    raise ClusterError(f"could not join the Ray cluster at {config.cluster}: {JOIN_HINT}") from err
        self.remote = ray.remote(run_pickled).options(max_retries=config.retries, num_cpus=1)
        self.lost = _lost_errors(ray)

    def close(self) -> None:
        if self.owned and self.ray.is_initialized():
            self.ray.shutdown()

    def map(self, key: str, job: Job, tasks: list[tuple]) -> Iterator[tuple[int, Any]]:
        """(task index, result) in completion order; see the module docstring for lost tasks."""
        ray = self.ray
        job_ref = ray.put(job)  # stored once, not once per task
        blobs = [pickle.dumps(t, protocol=pickle.HIGHEST_PROTOCOL) for t in tasks]
        pending = {self.remote.remote(key, job_ref, b): (i, 0) for i, b in enumerate(blobs)}
        try:
            while pending:
                (ref,), _ = ray.wait(list(pending), num_returns=1)
                i, resubmitted = pending.pop(ref)
                try:
                    result = pickle.loads(ray.get(ref))
                except self.lost as err:
                    if resubmitted >= self.config.resubmits:
                        raise
                    print(f"[batch] task {i} lost ({type(err).__name__}); submitted again", file=sys.stderr)
                    pending[self.remote.remote(key, job_ref, blobs[i])] = (i, resubmitted + 1)
                    continue
                yield i, result
        finally:
            for ref in pending:
                ray.cancel(ref, force=True)

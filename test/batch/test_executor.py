"""The executor's local paths: results by task index, a job's state built once per worker, errors raised, and
the default install never imports Ray."""

import operator
import os
import subprocess
import sys
import time
from pathlib import Path

import pytest

from latent_planner_ros.batch.executor import Executor, ExecutorConfig, Job, add_executor_args, executor_config

REPO = Path(__file__).resolve().parents[2]


# Spawned workers import a job's functions by name, and this test module has none they can import: the jobs here
# are made of standard-library functions.


@pytest.mark.parametrize("workers", [1, 2])
def test_every_task_comes_back_under_its_index_with_one_state_per_worker(workers):
    job = Job(operator.add, time.monotonic_ns)  # state: when the worker built it [ns]; a task adds x to it
    with Executor(ExecutorConfig(workers=workers)) as ex:
        out = dict(ex.map(job, [(x,) for x in range(6)]))
    assert ex.name == "processes"
    assert sorted(out) == list(range(6))
    built = {out[x] - x for x in range(6)}
    assert 1 <= len(built) <= workers  # built once in each worker, not once per task


def test_an_error_in_a_task_is_raised_by_map():
    with pytest.raises(ZeroDivisionError):
        with Executor(ExecutorConfig(workers=2)) as ex:
            list(ex.map(Job(operator.truediv), [(1, 1), (1, 0), (2, 1)]))


def test_the_flags_make_the_config():
    import argparse

    p = argparse.ArgumentParser()
    add_executor_args(p, workers=3)
    assert executor_config(p.parse_args([])) == ExecutorConfig(workers=3, cluster="")
    cfg = executor_config(p.parse_args(["--cluster", "10.0.0.5:6379", "--workers", "0"]))
    assert (cfg.cluster, cfg.workers, cfg.name) == ("10.0.0.5:6379", 0, "ray")
    with pytest.raises(ValueError):
        ExecutorConfig(retries=-1)


def test_the_default_install_runs_without_importing_ray():
    code = (
        "import sys, operator\n"
        "from latent_planner_ros.batch.executor import Executor, ExecutorConfig, Job\n"
        "import latent_planner_ros.bench.table, latent_planner_ros.bench.lspp, latent_planner_ros.data.dataset\n"
        "with Executor(ExecutorConfig(workers=1)) as ex:\n"
        "    assert dict(ex.map(Job(operator.add), [(1, 2)])) == {0: 3}\n"
        "assert 'ray' not in sys.modules, 'ray imported'\n"
    )
    env = {**os.environ, "PYTHONPATH": str(REPO)}
    done = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr[-2000:]


def test_without_ray_the_cluster_path_names_the_extra(monkeypatch):
    monkeypatch.setitem(sys.modules, "ray", None)  # `import ray` raises ImportError
    with pytest.raises(ImportError, match=r"pip install \.\[cluster\]"):
        with Executor(ExecutorConfig(cluster="auto")):
            pass

"""The Ray path on a local 2-CPU cluster started here: the same results as local processes (bench table problem by
problem, collision shards, distillation samples), a task whose worker dies is run again, and the cluster leaves no
process behind."""

import json
import os
import sys
import time
from pathlib import Path

import numpy as np
import pytest
import ray
import torch

from latent_planner_ros.batch.executor import Executor, ExecutorConfig, Job
from latent_planner_ros.bench.scenario_generator import GeneratorConfig, generate_set
from latent_planner_ros.bench.scenarios import save_scenarios
from latent_planner_ros.bench.table import main as bench_table
from latent_planner_ros.data.dataset import CollisionData, DatasetConfig, generate_dataset
from latent_planner_ros.data.queries import QuerySamplerConfig

pytestmark = pytest.mark.slow

ON_RAY = ExecutorConfig(workers=2, cluster="auto")
"""joins the module's cluster (a process already connected to Ray keeps its connection)"""


def _ray_processes() -> dict[int, str]:
    """pid -> command line of this process's descendants that belong to Ray."""
    children: dict[int, list[int]] = {}
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            pid, rest = stat.read_text().split(" (", 1)
            children.setdefault(int(rest.rsplit(") ", 1)[1].split()[1]), []).append(int(pid))
        except (OSError, IndexError, ValueError):
            continue
    out, todo = {}, [os.getpid()]
    while todo:
        for pid in children.get(todo.pop(), []):
            todo.append(pid)
            try:
                cmd = Path(f"/proc/{pid}/cmdline").read_bytes().replace(b"\0", b" ").decode()
            except OSError:
                continue
            if "ray" in cmd:
                out[pid] = cmd
    return out


def _alive(pid: int) -> bool:
    try:
        return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0] != "Z"
    except OSError:
        return False


@pytest.fixture(scope="module")
def cluster():
    """One local Ray cluster of 2 CPUs for the module; at the end, every Ray process it started is gone."""
    ray.init(address="local", num_cpus=2, include_dashboard=False, configure_logging=False)
    ray.cloudpickle.register_pickle_by_value(sys.modules[__name__])  # Ray workers cannot import this test module
    try:
        yield
        started = _ray_processes()
        assert any("raylet" in c for c in started.values()), started  # the snapshot sees the cluster
    finally:
        ray.shutdown()
    deadline = time.monotonic() + 20.0
    while any(_alive(p) for p in started) and time.monotonic() < deadline:
        time.sleep(0.2)
    assert not [started[p] for p in started if _alive(p)]


def _die_once(marker_dir: str, x: int) -> tuple[int, int]:
    """Task x; task 1 kills its own worker process the first time it runs (and leaves a marker with its pid)."""
    marker = Path(marker_dir) / "died"
    if x == 1 and not marker.exists():
        marker.write_text(str(os.getpid()))
        os._exit(1)
    return 10 * x, os.getpid()


def _refuse(x: int) -> int:
    raise ValueError(f"task {x} refuses")


@pytest.mark.parametrize(
    "config",
    [
        ExecutorConfig(workers=2, cluster="auto", retries=3, resubmits=0),  # re-run by Ray
        ExecutorConfig(workers=2, cluster="auto", retries=0, resubmits=1),  # lost for Ray, resubmitted here
    ],
    ids=["ray_retries", "driver_resubmits"],
)
def test_a_task_whose_worker_dies_is_run_again(cluster, tmp_path, config, capsys):
    with Executor(config) as ex:
        out = dict(ex.map(Job(_die_once), [(str(tmp_path), x) for x in range(4)]))
    assert {x: v[0] for x, v in out.items()} == {0: 0, 1: 10, 2: 20, 3: 30}
    dead = int((tmp_path / "died").read_text())  # the first run of task 1 did kill its worker
    assert out[1][1] != dead and not _alive(dead)
    if config.retries == 0:
        assert "task 1 lost (WorkerCrashedError); submitted again" in capsys.readouterr().err


def test_an_error_raised_by_a_task_is_raised_not_retried(cluster):
    with pytest.raises(ValueError, match="task 0 refuses"):
        with Executor(ON_RAY) as ex:
            list(ex.map(Job(_refuse), [(0,)]))


def _table(tmp_path: Path, scenarios: Path, name: str, flags: list[str]) -> dict:
    argv = ["--out", str(tmp_path / name), "--scenarios", str(scenarios), "--planners", "amp_ls"]
    assert bench_table([*argv, "--backend", "geometric", "--workers", "2", *flags]) == 0
    return json.loads((tmp_path / name / "table.json").read_text())


def test_bench_table_gives_the_same_outcomes_problem_by_problem(cluster, tmp_path):
    scenarios = save_scenarios(generate_set(GeneratorConfig(problems=4, seed=77), progress=False), tmp_path / "s.json")
    local = _table(tmp_path, scenarios, "processes", [])
    on_ray = _table(tmp_path, scenarios, "ray", ["--cluster", "auto"])
    assert (local["executor"], on_ray["executor"]) == ("processes", "ray")
    keys = ("problem", "planner", "success", "claimed", "reached", "collision", "reason", "pos_err_mm", "ee_path_m")
    assert len(local["rows"]) == len(on_ray["rows"]) == 4
    for a, b in zip(local["rows"], on_ray["rows"], strict=True):
        assert {k: a[k] for k in keys} == {k: b[k] for k in keys}
    assert local["planners"]["amp_ls"]["success"] == on_ray["planners"]["amp_ls"]["success"]


def test_collision_shards_are_the_same_on_ray(cluster, tmp_path):
    tiny = DatasetConfig(scenes_per_shard=2, pool=800, pool_refresh=40,
                         queries=QuerySamplerConfig(n_uniform=8, n_near=8, candidates=200))  # fmt: skip
    generate_dataset(tmp_path / "here", 6, seed=5, config=tiny, progress=False)
    with Executor(ON_RAY) as ex:
        generate_dataset(tmp_path / "ray", 6, seed=5, config=tiny, progress=False, executor=ex)
    here, there = CollisionData.load(tmp_path / "here"), CollisionData.load(tmp_path / "ray")
    assert len(there.shards) == 3 and len(there.scenes) == 6
    for name in ("q", "scene", "link_labels", "near"):
        np.testing.assert_array_equal(getattr(here, name), getattr(there, name))
    assert [s.to_dict() for s in here.scenes] == [s.to_dict() for s in there.scenes]


def test_distillation_samples_are_the_same_on_ray(cluster):
    from latent_planner_ros.models.collision_net import CollisionNet
    from latent_planner_ros.models.collision_predictor import CollisionPredictor
    from latent_planner_ros.training.distil_collision import teacher_samples

    predictor = CollisionPredictor.load(None)
    student = CollisionNet(predictor.net.config)
    x, y = teacher_samples(predictor, student, 3, "train", 4, 8)
    with Executor(ON_RAY) as ex:
        xr, yr = teacher_samples(predictor, student, 3, "train", 4, 8, executor=ex)
    assert x.shape[0] == 24 and torch.equal(x, xr) and torch.equal(y, yr)

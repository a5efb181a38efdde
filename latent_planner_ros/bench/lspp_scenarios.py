"""Obstacle scenarios of the seed's LSPP evaluation (chapter 6, IV-C), generated reproducibly.

A scenario has a start configuration, a target position (the TCP position of a sampled target configuration,
which no planner sees), and K upright cylinders (x, y, h, r). The first cylinder is placed between the start
and target TCP positions; each further one is, with probability 1/2 each, placed the same way or sampled
anywhere (CylinderRanges). Start and target configurations are free of every cylinder (so a collision-free
goal configuration exists), and, as in the seed, only scenarios where the planner WITHOUT the obstacle loss
collides with a cylinder are kept.
"""

from __future__ import annotations

import json
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np
from tqdm import tqdm

from latent_planner_ros.data.cylinders import CylinderRanges, cylinder_scene
from latent_planner_ros.data.labels import CollisionLabeler

BETWEEN = (0.3, 0.7)
"""a 'between' cylinder's axis passes through start + u (target - start), u in this range (xy plane)"""
BASE_CLEARANCE = 0.15
"""a cylinder's surface stays at least this far [m] from the base's z axis"""


@dataclass
class LsppScenario:
    """start (7,) [rad], target_q (7,) [rad] (hidden from planners), target (3,) [m], cylinders (K, 4)."""

    start: list[float]
    target_q: list[float]
    target: list[float]
    cylinders: list[list[float]]


def _between(rng: np.random.Generator, a: np.ndarray, b: np.ndarray, ranges: CylinderRanges) -> np.ndarray:
    xy = a[:2] + rng.uniform(*BETWEEN) * (b[:2] - a[:2])
    return np.array([xy[0], xy[1], rng.uniform(*ranges.height), rng.uniform(*ranges.radius)])


def _clear_of_base(o: np.ndarray) -> bool:
    return bool(np.hypot(o[0], o[1]) - o[3] >= BASE_CLEARANCE)


class ScenarioGenerator:
    """Draws scenarios with `k` cylinders; `no_col_planner.plan(start, goal)` is the filter planner."""

    def __init__(self, no_col_planner, seed: int, ranges: CylinderRanges | None = None):
        from latent_planner_ros.robot.panda import load_panda
        from latent_planner_ros.robot.sampler import FeasibleSampler

        self.rng = np.random.default_rng(seed)
        self.ranges = ranges or CylinderRanges()
        self.sampler = FeasibleSampler(self.rng)
        self.panda = load_panda()
        self.filter = no_col_planner
        self.tried = 0

    def draw(self, k: int) -> LsppScenario:
        """One kept scenario with k cylinders."""
        from latent_planner_ros.evaluation.path_check import PathJudge

        while True:
            self.tried += 1
            start, target_q = self.sampler.sample(2)
            a, b = self.panda.fk(start).translation, self.panda.fk(target_q).translation
            cyl = [_between(self.rng, a, b, self.ranges)]
            while len(cyl) < k:
                cyl.append(
                    _between(self.rng, a, b, self.ranges)
                    if self.rng.random() < 0.5
                    else self.ranges.sample(self.rng, 1)[0]
                )
            o = np.array(cyl)
            if not all(_clear_of_base(c) for c in o):
                continue
            scene = cylinder_scene(o)
            if CollisionLabeler(scene).label(np.stack([start, target_q])).any():
                continue
            goal = position_goal(b)
            result = self.filter.plan(start, goal)
            if PathJudge(scene).judge(result.q_path, goal).collision != "obstacle":
                continue
            return LsppScenario(start.tolist(), target_q.tolist(), b.tolist(), o.tolist())


def position_goal(target: np.ndarray):
    """A position-only goal (1 cm; any orientation) at target (3,) [m]."""
    from latent_planner_ros.planning.goal import Goal

    return Goal(np.asarray(target, dtype=float), np.eye(3), pos_tol=0.01, ori_tol=2 * np.pi)


def _draw_count(k: int, n: int, seed: int, vae=None, progress: bool = False) -> list[LsppScenario]:
    """n scenarios with k cylinders; the filter is LSPP without the obstacle loss (the shipped VAE if None)."""
    import torch

    from latent_planner_ros.models.vae_io import load_vae
    from latent_planner_ros.planning.amp_ls import AmpLs, presets
    from latent_planner_ros.planning.collision_backend import NoCollision

    torch.set_num_threads(1)
    no_col = AmpLs(
        vae if vae is not None else load_vae()[0], NoCollision(), presets.lspp_seed(use_collision=False), seed=seed
    )
    gen = ScenarioGenerator(no_col, seed=seed * 100 + k)
    return [gen.draw(k) for _ in tqdm(range(n), desc=f"scenarios, {k} cylinders", disable=not progress)]


def generate_scenarios(
    counts: list[int], n: int, seed: int, vae=None, progress: bool = True, workers: int = 1, executor=None
) -> dict[int, list[LsppScenario]]:
    """n scenarios for each obstacle count in `counts` (each count from its own seed, so the result does not
    depend on where it runs); the filter planner runs on `vae` (default: the shipped VAE). One task per count on
    `executor` (batch/executor.Executor; default: `workers` local processes); a given `vae` keeps every count in
    this process."""
    from latent_planner_ros.batch.executor import Executor, ExecutorConfig, Job

    ex = executor or Executor(ExecutorConfig(workers=workers))
    if vae is not None or (not ex.config.cluster and ex.config.workers <= 1):
        return {k: _draw_count(k, n, seed, vae, progress) for k in counts}
    bar = tqdm(total=len(counts), desc="scenario sets", disable=not progress)
    out = {}
    for i, drawn in ex.map(Job(_draw_count), [(k, n, seed) for k in counts]):
        out[counts[i]] = drawn
        bar.update()
    bar.close()
    return {k: out[k] for k in counts}


def save_scenarios(path: Path, scenarios: dict[int, list[LsppScenario]], meta: dict) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    payload = {"meta": meta, "obstacles": {str(k): [asdict(s) for s in v] for k, v in scenarios.items()}}
    path.write_text(json.dumps(payload) + "\n")


def load_scenarios(path: Path) -> tuple[dict[int, list[LsppScenario]], dict]:
    d = json.loads(Path(path).read_text())
    return {int(k): [LsppScenario(**s) for s in v] for k, v in d["obstacles"].items()}, d.get("meta", {})

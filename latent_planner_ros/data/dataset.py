"""Collision datasets on disk: scene specs + labelled configurations in shards (clouds are rendered on the fly).

A dataset directory holds shards ``shard_00000.npz`` + ``shard_00000.json``:
    npz: q (M, 7) float32 [rad], scene (M,) int32 index into the shard's scenes, link_labels (M, L) bool,
         near (M,) bool (drawn near the objects rather than uniformly);
    json: {"split", "family", "seed", "links", "scenes": [scene dicts], "config", "seconds"}.
Every shard is reproducible from (seed, split, shard index) alone, so generation can be spread over processes
and resumed: existing shards are skipped.
"""

from __future__ import annotations

import json
import os
import time
import zlib
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

from latent_planner_ros.data.labels import CollisionLabeler, link_poses
from latent_planner_ros.data.link_geometry import LABEL_LINKS
from latent_planner_ros.data.queries import QuerySamplerConfig, sample_query_indices
from latent_planner_ros.data.scene import Scene
from latent_planner_ros.data.scene_families import generate_family_scene
from latent_planner_ros.data.scene_generator import SceneGeneratorConfig
from latent_planner_ros.data.shapes import SHAPES_VERSION
from latent_planner_ros.robot.sampler import FeasibleSampler

DEFAULT_DATA_DIR = Path("data_cache/collision")


@dataclass(frozen=True)
class DatasetConfig:
    """What one shard holds and how it is generated."""

    family: str = "train"
    """scene family: "train" or "heldout" (tabletop), a workcell family, "workcell", "mix" (data/scene_families.py)"""
    scenes_per_shard: int = 25
    pool: int = 12_000
    """uniform feasible configurations kept per shard to draw queries from"""
    pool_refresh: int = 500
    """pool entries replaced by fresh samples after every scene"""
    queries: QuerySamplerConfig = field(default_factory=QuerySamplerConfig)
    scene: SceneGeneratorConfig = field(default_factory=SceneGeneratorConfig)

    def to_dict(self) -> dict:
        return asdict(self)


def shard_rng(seed: int, split: str, index: int) -> np.random.Generator:
    """The Generator of one shard: independent streams for every (seed, split, shard index)."""
    return np.random.default_rng(np.random.SeedSequence([seed, zlib.crc32(split.encode()), index]))


def shard_stem(directory: Path, index: int) -> Path:
    return Path(directory) / f"shard_{index:05d}"


def make_shard(split: str, index: int, seed: int, config: DatasetConfig) -> tuple[dict[str, np.ndarray], dict]:
    """One shard's arrays (q, scene, link_labels, near; see the module docstring) and metadata, from (seed,
    split, index) alone."""
    t0 = time.monotonic()
    rng = shard_rng(seed, split, index)
    sampler = FeasibleSampler(rng)
    pool = sampler.sample(config.pool)
    pool_poses = link_poses(pool)
    scenes, qs, labels, nears, scene_idx = [], [], [], [], []
    for k in range(config.scenes_per_shard):
        scene = generate_family_scene(rng, config.family, config.scene, seed=index * 1000 + k)
        idx, near = sample_query_indices(scene, pool, rng, config.queries, pool_poses)
        labels.append(CollisionLabeler(scene).label_poses(pool_poses[idx]))
        scenes.append(scene)
        qs.append(pool[idx].astype(np.float32))
        nears.append(near)
        scene_idx.append(np.full(len(idx), k, dtype=np.int32))
        fresh = rng.integers(0, len(pool), config.pool_refresh)
        pool[fresh] = sampler.sample(config.pool_refresh)
        pool_poses[fresh] = link_poses(pool[fresh])
    arrays = {
        "q": np.concatenate(qs),
        "scene": np.concatenate(scene_idx),
        "link_labels": np.concatenate(labels),
        "near": np.concatenate(nears),
    }
    meta = {
        "split": split,
        "family": config.family,
        "seed": seed,
        "index": index,
        "links": list(LABEL_LINKS),
        "config": config.to_dict(),
        "shapes_version": SHAPES_VERSION,
        "seconds": round(time.monotonic() - t0, 2),
        "scenes": [s.to_dict() for s in scenes],
    }
    return arrays, meta


def write_shard(directory: Path, index: int, arrays: dict[str, np.ndarray], meta: dict) -> Path:
    """Write one shard (atomically: its npz appears last); returns its .npz path."""
    stem = shard_stem(directory, index)
    stem.parent.mkdir(parents=True, exist_ok=True)
    tmp = stem.with_suffix(".tmp.npz")
    np.savez_compressed(tmp, **arrays)  # type: ignore[arg-type]  # mypy also matches **arrays to allow_pickle
    stem.with_suffix(".json").write_text(json.dumps(meta))
    os.replace(tmp, stem.with_suffix(".npz"))  # the npz appears last: a shard with an npz is complete
    return stem.with_suffix(".npz")


def generate_shard(directory: Path, split: str, index: int, seed: int, config: DatasetConfig) -> Path:
    """Generate and write one shard (atomically); returns its .npz path."""
    return write_shard(directory, index, *make_shard(split, index, seed, config))


def _shard_task(split: str, index: int, seed: int, config: DatasetConfig) -> tuple[dict[str, np.ndarray], dict]:
    import torch

    torch.set_num_threads(1)
    return make_shard(split, index, seed, config)


def generate_dataset(
    directory: str | Path,
    n_scenes: int,
    split: str = "train",
    seed: int = 0,
    config: DatasetConfig | None = None,
    workers: int = 1,
    progress: bool = True,
    executor=None,
) -> list[Path]:
    """Make sure `directory` holds the first ceil(n_scenes / scenes_per_shard) shards of (seed, split).

    Missing shards are generated one task each on `executor` (batch/executor.Executor, local processes or a Ray
    cluster; default: `workers` local processes, 1 = in this process) and written here as they come back, so an
    interrupted run keeps its finished shards; returns the .npz paths.
    """
    from tqdm import tqdm

    from latent_planner_ros.batch.executor import Executor, ExecutorConfig, Job

    cfg = config or DatasetConfig()
    directory = Path(directory)
    n_shards = -(-n_scenes // cfg.scenes_per_shard)
    todo = [i for i in range(n_shards) if not shard_stem(directory, i).with_suffix(".npz").exists()]
    bar = tqdm(total=n_shards * cfg.scenes_per_shard, initial=(n_shards - len(todo)) * cfg.scenes_per_shard,
               unit="scene", desc=f"{split} scenes", disable=not progress, dynamic_ncols=True)  # fmt: skip
    ex = executor or Executor(ExecutorConfig(workers=workers))
    for k, (arrays, meta) in ex.map(Job(_shard_task), [(split, i, seed, cfg) for i in todo]):
        write_shard(directory, todo[k], arrays, meta)
        bar.update(cfg.scenes_per_shard)
    bar.close()
    return [shard_stem(directory, i).with_suffix(".npz") for i in range(n_shards)]


@dataclass
class CollisionData:
    """Labelled configurations of many scenes, concatenated over shards.

    Attributes:
        scenes: every scene, in shard order.
        q: (M, 7) float32 [rad] configurations.
        scene: (M,) int64 index into `scenes`.
        link_labels: (M, L) bool per-link collision.
        near: (M,) bool, drawn near the objects.
        shards: the shard files loaded.
    """

    scenes: list[Scene]
    q: np.ndarray
    scene: np.ndarray
    link_labels: np.ndarray
    near: np.ndarray
    shards: list[Path]

    @property
    def labels(self) -> np.ndarray:
        """(M,) bool: in collision with any link."""
        return np.asarray(self.link_labels.any(1))

    @classmethod
    def empty(cls, n_links: int = len(LABEL_LINKS)) -> CollisionData:
        return cls(
            [], np.zeros((0, 7), np.float32), np.zeros(0, np.int64), np.zeros((0, n_links), bool), np.zeros(0, bool), []
        )

    def first(self, n_scenes: int) -> CollisionData:
        """The first n_scenes scenes and their configurations."""
        keep = self.scene < n_scenes
        return CollisionData(
            self.scenes[:n_scenes],
            self.q[keep],
            self.scene[keep],
            self.link_labels[keep],
            self.near[keep],
            list(self.shards),
        )

    def add_shard(self, path: Path) -> None:
        """Append one shard (npz + json); raises ValueError if it is unreadable or its links differ."""
        self.add_shards([path])

    def add_shards(self, paths: list[Path]) -> None:
        """Append shards (npz + json) in order, concatenating once; raises ValueError naming a bad shard."""
        parts: dict[str, list[np.ndarray]] = {k: [getattr(self, k)] for k in ("q", "scene", "link_labels", "near")}
        scenes = list(self.scenes)
        for path in map(Path, paths):
            try:
                meta = json.loads(path.with_suffix(".json").read_text())
                with np.load(path) as z:
                    arrays = {k: z[k] for k in ("q", "scene", "link_labels", "near")}
            except (OSError, ValueError, KeyError) as e:
                raise ValueError(f"collision data shard {path} is unreadable: {e}") from e
            if tuple(meta["links"]) != LABEL_LINKS:
                raise ValueError(f"shard {path} labels links {meta['links']}, expected {list(LABEL_LINKS)}")
            parts["q"].append(arrays["q"].astype(np.float32))
            parts["scene"].append(arrays["scene"].astype(np.int64) + len(scenes))
            parts["link_labels"].append(arrays["link_labels"].astype(bool))
            parts["near"].append(arrays["near"].astype(bool))
            scenes += [Scene.from_dict(s) for s in meta["scenes"]]
        for k, v in parts.items():
            setattr(self, k, np.concatenate(v))
        self.scenes = scenes
        self.shards += list(map(Path, paths))

    def refresh(self, directory: str | Path, limit: int | None = None) -> int:
        """Load complete shards of `directory` not loaded yet (up to `limit` in total); returns how many."""
        have = {p.name for p in self.shards}
        new = [
            p
            for p in sorted(Path(directory).glob("shard_*.npz"))
            if p.name not in have and not p.name.endswith(".tmp.npz")
        ]
        if limit is not None:
            new = new[: max(0, limit - len(self.shards))]
        self.add_shards(new)
        return len(new)

    @classmethod
    def load(cls, directory: str | Path, limit: int | None = None) -> CollisionData:
        """Every complete shard of a dataset directory (or the first `limit`)."""
        data = cls.empty()
        data.refresh(directory, limit)
        return data

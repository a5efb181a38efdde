"""Labelled (q, o, c) samples for LSPP's obstacle classifier (seed chapter 6, IV-B).

q is a feasible configuration (inside the joint limits, free of self and table collision), o = (x, y, h, r) one
upright cylinder, c whether the arm's collision meshes touch it (exact, coal). The set is balanced: as many
colliding as free samples. Cached as one .npz (no pickles).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
from tqdm import tqdm

from latent_planner_ros.data.cylinders import CylinderRanges, cylinder_scene
from latent_planner_ros.data.labels import CollisionLabeler, link_poses
from latent_planner_ros.robot.sampler import FeasibleSampler


@dataclass
class CylinderData:
    """q (N, 7) [rad], o (N, 4) (x, y, h, r) [m], c (N,) bool."""

    q: np.ndarray
    o: np.ndarray
    c: np.ndarray

    def save(self, path: str | Path) -> Path:
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = path.with_suffix(".tmp.npz")
        np.savez_compressed(tmp, q=self.q, o=self.o, c=self.c)
        tmp.replace(path)
        return path

    @classmethod
    def load(cls, path: str | Path) -> CylinderData:
        with np.load(Path(path), allow_pickle=False) as f:
            return cls(q=f["q"], o=f["o"], c=f["c"].astype(bool))

    def __len__(self) -> int:
        return len(self.c)


def label_pairs(q: np.ndarray, o: np.ndarray) -> np.ndarray:
    """Exact labels (N,) bool of configurations q (N, 7) [rad] against one cylinder each, o (N, 4)."""
    poses = link_poses(q)
    return np.array(
        [CollisionLabeler(cylinder_scene(oi[None])).label_poses(poses[i : i + 1]).any() for i, oi in enumerate(o)]
    )


def generate(
    n: int,
    seed: int,
    ranges: CylinderRanges | None = None,
    per_cylinder: int = 64,
    pool: int = 50_000,
    progress: bool = True,
) -> CylinderData:
    """A balanced set of n samples (n/2 colliding, n/2 free), in random order.

    Each sampled cylinder is labelled against `per_cylinder` configurations drawn from a pool of feasible ones;
    samples of the class that is already full are dropped.
    """
    rng = np.random.default_rng(seed)
    ranges = ranges or CylinderRanges()
    q_pool = FeasibleSampler(rng).sample(pool)
    poses = link_poses(q_pool)
    half = n // 2
    got: dict[bool, list[tuple[np.ndarray, np.ndarray]]] = {True: [], False: []}
    counts = {True: 0, False: 0}
    bar = tqdm(total=2 * half, desc="labelling", unit="sample", disable=not progress, mininterval=1.0)
    while counts[True] < half or counts[False] < half:
        o = ranges.sample(rng, 1)
        idx = rng.choice(pool, size=per_cylinder, replace=False)
        hits = CollisionLabeler(cylinder_scene(o)).label_poses(poses[idx]).any(axis=1)
        for label in (True, False):
            take = idx[hits == label][: half - counts[label]]
            if len(take):
                got[label].append((q_pool[take], np.repeat(o, len(take), axis=0)))
                counts[label] += len(take)
                bar.update(len(take))
    bar.close()
    q = np.concatenate([a for label in (True, False) for a, _ in got[label]])
    o = np.concatenate([b for label in (True, False) for _, b in got[label]])
    c = np.concatenate([np.full(counts[label], label) for label in (True, False)])
    order = rng.permutation(len(c))
    return CylinderData(q=q[order], o=o[order], c=c[order])

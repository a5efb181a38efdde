"""Clouds and batches for the local collision predictor (models/local_collision.py).

Each scene of a collision dataset (data/dataset.py: scenes with exactly labelled configurations) is seen once,
by 1-3 cameras whose clouds are fused (as the workcell sets and the sim's camera rig give them: a tabletop scene
by one camera in `bench collision`); the clouds are rendered once, in worker processes, and cached. A batch is
configurations of a few scenes with their link poses and the neighbourhoods of their links in the scene's cloud.
"""

from __future__ import annotations

from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
import torch
from scipy.spatial import cKDTree
from tqdm import tqdm

from latent_planner_ros.data.camera import CameraConfig, planning_crop
from latent_planner_ros.data.dataset import CollisionData
from latent_planner_ros.data.link_geometry import LABEL_LINKS
from latent_planner_ros.data.render import fused_view
from latent_planner_ros.data.scene import Scene
from latent_planner_ros.models.local_collision import LocalCollisionNet, Neighbourhoods
from latent_planner_ros.robot.panda import LINK_FRAMES
from latent_planner_ros.robot.torch_fk import TorchFK


def planning_camera() -> CameraConfig:
    """The data camera, cropped as the planners' clouds are (the arm's reach)."""
    low, high = planning_crop()
    return replace(CameraConfig(), crop_min=low, crop_max=high)


def scene_views(scene: Scene, rng: np.random.Generator, views: int) -> tuple[np.ndarray, np.ndarray]:
    """`views` random views of a scene fused (data/render.fused_view, aimed at its obstacles): the
    cloud (N, 3) float32 [m] and each point's camera origin (N, 3) float32 [m]."""
    return fused_view(scene, rng, planning_camera(), views)


def _render(args: tuple[list[dict], int, int, tuple[int, int]]) -> list[tuple[np.ndarray, np.ndarray]]:
    scenes, seed, first, views = args
    out = []
    for k, s in enumerate(scenes):
        rng = np.random.default_rng([seed, first + k])
        scene = Scene.from_dict(s)
        n = int(rng.integers(views[0], views[1] + 1))
        out.append(scene_views(scene, rng, n))
    return out


@dataclass
class SceneClouds:
    """One fused cloud per scene: points (P, 3) float32 [m], camera origins (P, 3) float32 [m], and each scene's
    row range offsets (S + 1,)."""

    points: np.ndarray
    eyes: np.ndarray
    offsets: np.ndarray

    def cloud(self, i: int) -> tuple[np.ndarray, np.ndarray]:
        a, b = self.offsets[i], self.offsets[i + 1]
        return self.points[a:b], self.eyes[a:b]

    def save(self, path: Path) -> None:
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = path.with_suffix(".tmp.npz")
        np.savez(tmp, points=self.points, eyes=self.eyes, offsets=self.offsets)
        tmp.replace(path)

    @classmethod
    def load(cls, path: Path) -> SceneClouds:
        with np.load(path) as z:
            return cls(z["points"], z["eyes"], z["offsets"])

    @classmethod
    def render(
        cls, scenes: list[Scene], seed: int, views: tuple[int, int], workers: int = 1, chunk: int = 25
    ) -> SceneClouds:
        """Render every scene (views[0]-views[1] cameras each, seeded by (seed, scene index)) in `workers`
        processes, with a progress bar."""
        dicts = [s.to_dict() for s in scenes]
        tasks = [(dicts[i : i + chunk], seed, i, views) for i in range(0, len(dicts), chunk)]
        clouds: list[tuple[np.ndarray, np.ndarray]] = []
        bar = tqdm(total=len(scenes), desc="rendering clouds", unit="scene")
        if workers <= 1:
            for t in tasks:
                clouds += _render(t)
                bar.update(len(t[0]))
        else:
            with ProcessPoolExecutor(workers) as pool:
                for part in pool.map(_render, tasks):
                    clouds += part
                    bar.update(len(part))
        bar.close()
        sizes = np.array([len(c) for c, _ in clouds])
        offsets = np.concatenate([[0], np.cumsum(sizes)]).astype(np.int64)
        points = np.concatenate([c for c, _ in clouds]) if clouds else np.zeros((0, 3), np.float32)
        eyes = np.concatenate([e for _, e in clouds]) if clouds else np.zeros((0, 3), np.float32)
        return cls(points.astype(np.float32), eyes.astype(np.float32), offsets)

    @classmethod
    def cached(cls, path: Path, scenes: list[Scene], seed: int, views: tuple[int, int], workers: int) -> SceneClouds:
        """The clouds at `path` if they hold these scenes, else rendered and saved there."""
        if path.exists():
            clouds = cls.load(path)
            if len(clouds.offsets) == len(scenes) + 1:
                return clouds
        clouds = cls.render(scenes, seed, views, workers)
        clouds.save(path)
        return clouds


class BatchMaker:
    """Link poses, neighbourhoods and labels of configurations of one dataset with its clouds."""

    def __init__(self, data: CollisionData, clouds: SceneClouds, net: LocalCollisionNet, eyes: bool = True):
        self.data, self.clouds, self.net, self.use_eyes = data, clouds, net, eyes
        self._fk = TorchFK()
        self._frames = [LINK_FRAMES.index(n) for n in LABEL_LINKS]
        self._anchors = net.anchors_np()
        starts = np.searchsorted(data.scene, np.arange(len(data.scenes) + 1))
        self.rows = [np.arange(starts[i], starts[i + 1]) for i in range(len(data.scenes))]

    def scene_batch(self, scene: int, rows: np.ndarray) -> tuple[torch.Tensor, Neighbourhoods]:
        """Link poses (M, L, 4, 4) and neighbourhoods of the configurations `rows` (M,) of `scene`."""
        cloud, eyes = self.clouds.cloud(scene)
        frames = self._fk.frames_np(self.data.q[rows])[:, self._frames]
        tree = cKDTree(cloud) if len(cloud) else None
        nb = Neighbourhoods.of(tree, cloud, eyes if self.use_eyes else None, frames, self._anchors, self.net.config)
        return torch.as_tensor(frames, dtype=torch.float32), nb

    def labels(self, rows: np.ndarray) -> torch.Tensor:
        """Per-link labels (M, L) float32 of rows (M,)."""
        return torch.as_tensor(self.data.link_labels[rows], dtype=torch.float32)


def cat_neighbourhoods(parts: list[Neighbourhoods]) -> Neighbourhoods:
    """Neighbourhoods of several scenes' batches, concatenated along the batch."""
    return Neighbourhoods(
        torch.cat([p.points for p in parts]), torch.cat([p.eyes for p in parts]), torch.cat([p.valid for p in parts])
    )

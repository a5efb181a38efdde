"""The training loop state of the collision network: batches, hard mining, evaluation, checkpoints."""

from __future__ import annotations

import json
import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import torch
import torch.nn.functional as F

from latent_planner_ros.data.camera import CameraConfig, CameraIntrinsics
from latent_planner_ros.data.dataset import CollisionData
from latent_planner_ros.data.obstacle_geometry import triangle_mesh
from latent_planner_ros.data.obstacles import vec3
from latent_planner_ros.data.render import scene_view, voxel_downsample
from latent_planner_ros.models.checkpoint import load_checkpoint, load_state_into, save_checkpoint
from latent_planner_ros.models.collision_io import save_collision_net
from latent_planner_ros.models.collision_metrics import auroc, precision_recall
from latent_planner_ros.models.collision_net import CollisionNet
from latent_planner_ros.models.collision_net_config import CollisionNetConfig
from latent_planner_ros.models.vae import RobotStateVAE
from latent_planner_ros.training.train_collision_config import TrainCollisionConfig


class EvalSet:
    """Fixed validation scenes: one cloud per scene (seeded viewpoint) with its camera origin, and all their
    labelled configurations."""

    def __init__(self, data: CollisionData, seed: int, camera: CameraConfig):
        rng = np.random.default_rng(seed)
        self.data = data
        views = [scene_view(s, rng, camera) for s in data.scenes]
        self.clouds, self.eyes = [v[0] for v in views], [v[1] for v in views]


def box_camera(net_config: CollisionNetConfig) -> CameraConfig:
    """The data camera with its crop at the network's workspace box (the points the network is given)."""
    enc = net_config.encoder
    return replace(CameraConfig(), crop_min=enc.bounds_min, crop_max=enc.bounds_max)


def link_losses(
    net: CollisionNet, link_logits: torch.Tensor, y: torch.Tensor, y_link: torch.Tensor, link_loss_weight: float
) -> tuple[torch.Tensor, torch.Tensor]:
    """Per-query loss (...) = global BCE + link_loss_weight * mean per-link BCE, and the global logits."""
    logit = net.combine(link_logits)
    per = F.binary_cross_entropy_with_logits(logit, y, reduction="none")
    per_link = F.binary_cross_entropy_with_logits(link_logits, y_link, reduction="none").mean(-1)
    return per + link_loss_weight * per_link, logit


def query_tensors(
    data: CollisionData, rows: np.ndarray, vae: RobotStateVAE, device: torch.device
) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor, torch.Tensor]:
    """q (S, M, 7), z (S, M, latent), global labels (S, M), link labels (S, M, L) for rows (S, M) of `data`."""
    q = torch.as_tensor(data.q[rows], device=device)
    with torch.no_grad():
        z = vae.encode_q(q.reshape(-1, 7)).reshape(*rows.shape, -1)
    link = torch.as_tensor(data.link_labels[rows], dtype=torch.float32, device=device)
    return q, z, link.amax(-1), link


@torch.no_grad()
def evaluate_net(
    net: CollisionNet, vae: RobotStateVAE, ev: EvalSet, config: TrainCollisionConfig, device: torch.device
) -> dict:
    """Loss, AUROC (all and near configurations) and near precision/recall at config.threshold of `net` on a
    validation set (one cloud per scene, as rendered in `ev`)."""
    d = ev.data
    ps, losses = [], []
    for i, (cloud, eye) in enumerate(zip(ev.clouds, ev.eyes, strict=True)):
        rows = np.flatnonzero(d.scene == i)[None]
        eyes = torch.as_tensor(eye, dtype=torch.float32, device=device)[None]
        grid = net.encoder(torch.as_tensor(cloud).to(device), eyes=eyes)
        q, z, y, y_link = query_tensors(d, rows, vae, device)
        per, logit = link_losses(net, net.link_logits(grid, q, z), y, y_link, config.link_loss_weight)
        ps.append(torch.sigmoid(logit)[0].cpu().numpy())
        losses.append(per.mean().item())
    p, labels, near = np.concatenate(ps), d.labels, d.near
    prec, rec = precision_recall(p[near], labels[near], config.threshold)
    return {"loss": float(np.mean(losses)), "auroc": auroc(p, labels), "auroc_near": auroc(p[near], labels[near]),
            "precision_near": prec, "recall_near": rec}  # fmt: skip


class CollisionTrainer:
    """Owns the network, optimiser, data, RNG and history of one training run.

    Args:
        config: hyperparameters.
        net_config: architecture of a new network.
        vae: the frozen VAE whose latent the network reads.
        data: the training data (grows on refresh).
        val: {"seen": EvalSet, "unseen": EvalSet}; model selection uses "seen" only.
        out: run directory.
    """

    def __init__(
        self,
        config: TrainCollisionConfig,
        net_config: CollisionNetConfig,
        vae: RobotStateVAE,
        data: CollisionData,
        val: dict[str, EvalSet],
        out: Path,
        device: torch.device,
    ):
        self.config = config
        self.device = device
        self.net = CollisionNet(net_config).to(device)
        self.vae = vae.to(device).eval().requires_grad_(False)
        self.data = data
        self.val = val
        self.out = out
        self.camera = box_camera(net_config)
        self.rng = np.random.default_rng(config.seed)
        self.opt = torch.optim.Adam(self.net.parameters(), lr=config.lr, weight_decay=config.weight_decay)
        self.iteration = 0
        self.elapsed = 0.0
        self.history: list[dict] = []
        self.best_score = -math.inf
        self._index_scenes()

    # -- data -----------------------------------------------------------------------------------
    def _index_scenes(self) -> None:
        """Per scene, the row ranges of its uniform and near configurations (rows are grouped by scene)."""
        d = self.data
        n = len(d.scenes)
        starts = np.searchsorted(d.scene, np.arange(n + 1))
        self._rows = [np.arange(starts[i], starts[i + 1]) for i in range(n)]
        self._near = [r[d.near[r]] for r in self._rows]
        self._uniform = [r[~d.near[r]] for r in self._rows]

    def refresh(self) -> int:
        """Load shards that appeared in the data directory since the last call; returns how many."""
        added = self.data.refresh(self.config.data)
        if added:
            self._index_scenes()
        return added

    def _pick(self, scene: int, n: int) -> np.ndarray:
        n_near = int(round(n * self.config.near_fraction)) if len(self._near[scene]) else 0
        near = self.rng.choice(self._near[scene], n_near) if n_near else np.zeros(0, dtype=int)
        pool = self._uniform[scene] if len(self._uniform[scene]) else self._rows[scene]
        return np.concatenate([near, self.rng.choice(pool, n - n_near)])

    def _cloud(self, scene: int) -> tuple[np.ndarray, np.ndarray]:
        """A training cloud (N, 3) of a scene (config.views random viewpoints fused, randomised intrinsics and
        density) and the origin (N, 3) [m] of the camera that saw each point, all NaN with probability
        `unknown_eye_prob`."""
        c, rng = self.config, self.rng
        n_views = int(rng.integers(int(c.views[0]), int(c.views[1]) + 1))
        clouds, origins = [], []
        for _ in range(n_views):
            pts, eye = self._view(self.data.scenes[scene])
            clouds.append(pts)
            origins.append(np.repeat(eye[None].astype(np.float32), len(pts), 0))
        pts, eyes = np.concatenate(clouds), np.concatenate(origins).reshape(-1, 3)
        if rng.random() < c.unknown_eye_prob:
            eyes[:] = np.nan
        return pts, eyes

    def _view(self, scene) -> tuple[np.ndarray, np.ndarray]:
        """One random view (N, 3) of a scene, thinned or voxel-downsampled, and its camera origin (3,) [m]."""
        c, rng = self.config, self.rng
        scale = rng.uniform(*c.image_scale)
        intrinsics = CameraIntrinsics.from_fov(int(192 * scale), int(144 * scale), rng.uniform(*c.fovy_deg))
        camera = replace(self.camera, intrinsics=intrinsics)
        if scene.obstacles and rng.random() < c.aim_at_objects:
            target = triangle_mesh(scene.obstacles[int(rng.integers(len(scene.obstacles)))])[0].mean(0)
            camera = replace(camera, target=vec3(target))
        pts, eye = scene_view(scene, rng, camera)
        if rng.random() < c.voxel_downsample_prob:
            return voxel_downsample(pts, rng.uniform(*c.voxel_downsample_size)), eye
        return pts[rng.random(len(pts)) < rng.uniform(*c.point_keep)], eye

    def _encode(self, clouds: list[torch.Tensor], origins: list[np.ndarray], batch: torch.Tensor) -> torch.Tensor:
        """Feature grids (S, C, nx, ny, nz) of S clouds with their per-point camera origins (N_k, 3): one origin
        per cloud where each cloud has one camera (the computation the planners use then), else per point."""
        points, batch = torch.cat(clouds).to(self.device), batch.to(self.device)
        singles = [o[:1] if len(o) and (np.all(o == o[:1]) or np.isnan(o).all()) else None for o in origins]
        if all(s is not None or not len(o) for s, o in zip(singles, origins, strict=True)):
            rows = [s[0] if s is not None else np.full(3, np.nan, dtype=np.float32) for s in singles]
            eyes = torch.as_tensor(np.stack(rows), dtype=torch.float32, device=self.device)
            return self.net.encoder(points, batch, len(clouds), eyes)
        per_point = torch.as_tensor(np.concatenate(origins), dtype=torch.float32, device=self.device)
        return self.net.encoder(points, batch, len(clouds), point_eyes=per_point)

    def _tensors(
        self, rows: np.ndarray, data: CollisionData | None = None
    ) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor, torch.Tensor]:
        """query_tensors of rows (S, M) of `data` (default: the training data)."""
        return query_tensors(self.data if data is None else data, rows, self.vae, self.device)

    def losses(
        self, link_logits: torch.Tensor, y: torch.Tensor, y_link: torch.Tensor
    ) -> tuple[torch.Tensor, torch.Tensor]:
        """Per-query loss (...) and the global logits (`link_losses`)."""
        return link_losses(self.net, link_logits, y, y_link, self.config.link_loss_weight)

    # -- one step -------------------------------------------------------------------------------
    def step(self, lr: float) -> dict:
        c = self.config
        s, m = c.scenes_per_step, c.queries_per_scene
        scenes = self.rng.choice(len(self.data.scenes), s, replace=len(self.data.scenes) < s)
        views = [self._cloud(i) for i in scenes]
        clouds = [torch.as_tensor(v[0]) for v in views]
        batch = torch.cat([torch.full((len(p),), k, dtype=torch.long) for k, p in enumerate(clouds)])
        grid = self._encode(clouds, [v[1] for v in views], batch)
        n_hard = int(round(m * c.hard_fraction))
        rows = np.stack([self._pick(i, m - n_hard) for i in scenes])
        if n_hard:
            cand = np.stack([self._pick(i, n_hard * c.hard_candidates) for i in scenes])
            q_c, z_c, y_c, yl_c = self._tensors(cand)
            with torch.no_grad():
                loss_c, _ = self.losses(self.net.link_logits(grid.detach(), q_c, z_c), y_c, yl_c)
            hard = torch.topk(loss_c, n_hard, dim=1).indices.cpu().numpy()
            rows = np.concatenate([rows, np.take_along_axis(cand, hard, 1)], 1)
        q, z, y, y_link = self._tensors(rows)
        per, logit = self.losses(self.net.link_logits(grid, q, z), y, y_link)
        loss = per.mean()
        for g in self.opt.param_groups:
            g["lr"] = lr
        self.opt.zero_grad(set_to_none=True)
        loss.backward()
        torch.nn.utils.clip_grad_norm_(self.net.parameters(), 10.0)
        self.opt.step()
        self.iteration += 1
        with torch.no_grad():
            pred = torch.sigmoid(logit) >= c.threshold
            pos = y > 0.5
            acc = (pred == pos).float().mean().item()
            recall = (pred & pos).sum().item() / max(pos.sum().item(), 1)
        return {"loss": loss.item(), "acc": acc, "recall": recall, "pos_frac": pos.float().mean().item()}

    # -- evaluation -----------------------------------------------------------------------------
    def evaluate_set(self, ev: EvalSet) -> dict:
        """AUROC (all and near configurations) and precision/recall at the threshold on a validation set."""
        self.net.eval()
        try:
            return evaluate_net(self.net, self.vae, ev, self.config, self.device)
        finally:
            self.net.train()

    def evaluate(self, last: dict, lr: float) -> dict:
        m = {
            "iteration": self.iteration,
            "elapsed_s": round(self.elapsed, 1),
            "lr": lr,
            "scenes": len(self.data.scenes),
        }
        m.update({f"train_{k}": v for k, v in last.items()})
        for name, ev in self.val.items():
            m.update({f"val_{name}_{k}": v for k, v in self.evaluate_set(ev).items()})
        self.history.append(m)
        return m

    # -- checkpoints ----------------------------------------------------------------------------
    def save(self, metrics: dict, meta: dict) -> bool:
        """Write OUT/last (resumable) and, if the seen validation near-AUROC improved, OUT/best; True if best."""
        score = metrics.get("val_seen_auroc_near", -metrics.get("val_seen_loss", 0.0))
        score = -math.inf if score is None or math.isnan(score) else score
        improved = score > self.best_score
        training = {
            **meta.get("training", {}),
            "iterations": self.iteration,
            "duration_s": round(self.elapsed, 1),
            "device": str(self.device),
            "threads": torch.get_num_threads(),
            "scenes": len(self.data.scenes),
        }
        info = {**meta, "training": training, "metrics": metrics, "history": self.history}
        if improved:
            self.best_score = score
            save_collision_net(self.out / "best", self.net, info)
        tensors = {f"model.{k}": v for k, v in self.net.state_dict().items()}
        for i, st in self.opt.state_dict()["state"].items():
            tensors[f"opt.{i}.exp_avg"] = st["exp_avg"]
            tensors[f"opt.{i}.exp_avg_sq"] = st["exp_avg_sq"]
            tensors[f"opt.{i}.step"] = torch.as_tensor(st["step"]).reshape(1).float()
        state = {
            "kind": "collision_training_state",
            "config": self.config.to_dict(),
            "architecture": self.net.config.to_dict(),
            "iteration": self.iteration,
            "elapsed_s": self.elapsed,
            "best_score": self.best_score,
            "rng": self.rng.bit_generator.state,
            "history": self.history,
        }
        save_checkpoint(self.out / "last", tensors, state)
        (self.out / "history.json").write_text(json.dumps(self.history, indent=1))
        return improved

    def resume(self) -> None:
        """Continue from OUT/last: weights, optimiser moments, counters, RNG and history."""
        tensors, state = load_checkpoint(self.out / "last")
        load_state_into(self.net, {k[6:]: v for k, v in tensors.items() if k.startswith("model.")}, self.out / "last")
        sd = self.opt.state_dict()
        for i in range(len(list(self.net.parameters()))):
            if f"opt.{i}.exp_avg" in tensors:
                sd["state"][i] = {
                    "exp_avg": tensors[f"opt.{i}.exp_avg"].to(self.device),
                    "exp_avg_sq": tensors[f"opt.{i}.exp_avg_sq"].to(self.device),
                    "step": tensors[f"opt.{i}.step"].reshape(()),
                }
        self.opt.load_state_dict(sd)
        self.iteration = int(state["iteration"])
        self.elapsed = float(state["elapsed_s"])
        self.best_score = float(state["best_score"])
        self.rng.bit_generator.state = state["rng"]
        self.history = list(state["history"])

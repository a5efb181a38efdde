"""The scoring of `bench collision`: benchmark scenes, one fused or single view per scene, the predictor's and the
geometric reference's scores, and their summaries (AUROC, precision and recall, hidden and out-of-box splits).

Shared by the main benchmark (bench/collision.py) and its per-family report (bench/collision_families.py).
"""

from __future__ import annotations

import time
from dataclasses import replace
from pathlib import Path

import numpy as np
import torch
from scipy.spatial import cKDTree
from tqdm import tqdm

from latent_planner_ros.bench.collision_models import Predictor, combine, predictor_box
from latent_planner_ros.data.camera import CameraConfig, planning_crop
from latent_planner_ros.data.dataset import CollisionData, DatasetConfig, generate_dataset
from latent_planner_ros.data.labels import CollisionLabeler, link_poses
from latent_planner_ros.data.link_geometry import LABEL_LINKS, link_geometry
from latent_planner_ros.data.queries import QuerySamplerConfig
from latent_planner_ros.data.render import fused_view, scene_cloud, scene_view
from latent_planner_ros.models.collision_metrics import (
    auroc,
    calibration_bins,
    precision_recall,
    recall_at_precision,
    recall_by_bins,
)
from latent_planner_ros.models.local_predictor import LocalPredictor
from latent_planner_ros.perception.scene_input import inside_bounds

BENCH_SEED = 1000
"""Seed of the benchmark splits ("bench_seen", "bench_unseen"); training uses 0, validation 7."""
SHARD = 10
HIDDEN_M = 0.015
"""A collision is "hidden" when no cloud point lies within this distance [m] of the arm's surface points: the
camera saw nothing of what the arm hits, so only a prior over shapes can predict it."""
GAP_EDGES_M = (0.0, 0.005, 0.01, HIDDEN_M, 0.03, 0.06, np.inf)
"""bins of the distance [m] from the arm's surface points to the nearest cloud point, for recall per bin"""


def bench_data(root: Path, family: str, name: str, n_scenes: int, per_kind: int, executor=None) -> CollisionData:
    """The first n_scenes benchmark scenes of a family (generated once, one shard per task on `executor`,
    batch/executor.Executor, default in this process; cached under root/bench_<name>)."""
    cfg = DatasetConfig(
        family=family, scenes_per_shard=SHARD, queries=QuerySamplerConfig(n_uniform=per_kind, n_near=per_kind)
    )
    directory = root / f"bench_{name}_q{per_kind}"
    generate_dataset(directory, n_scenes, split=f"bench_{name}", seed=BENCH_SEED, config=cfg, executor=executor)
    return CollisionData.load(directory, limit=-(-n_scenes // SHARD)).first(n_scenes)


def geometric_score(q: np.ndarray, tree: cKDTree) -> np.ndarray:
    """Minus the smallest distance (N,) [m] from the links' surface points at q (N, 7) to the cloud."""
    poses = link_poses(q)
    pts = np.einsum("nlij,lsj->nlsi", poses[..., :3, :3], link_geometry().surface_points) + poses[:, :, None, :3, 3]
    d, _ = tree.query(pts.reshape(-1, 3))
    return -d.reshape(len(q), -1).min(1)


WORKCELL_VIEWS = 3
"""cameras fused per workcell scene (furniture is seen into from several sides, as the workcell sets do)"""


def evaluate_family(pred: Predictor, data: CollisionData, seed: int, with_origin: bool = True, views: int = 1) -> dict:
    """Scores of the predictor and the geometric reference on every labelled configuration of `data`; the
    predictor is given each cloud's camera origin (one per point for several views) unless with_origin is False.

    Each cloud (one random view, or `views` views fused: `fused_view`) is cropped like the sim camera's
    (`planning_crop`, up to the arm's reach), as the planners get it; the predictor encodes the points inside its
    network's box (as the planner and the scene_encoder node crop them), the geometric reference uses them all."""
    rng = np.random.default_rng(seed)
    low, high = planning_crop()
    camera = replace(CameraConfig(), crop_min=low, crop_max=high)
    box_min, box_max = predictor_box(pred)
    p, link_p, geo, enc_ms, n_points = [], [], [], [], []
    scenes = tqdm(data.scenes, desc="bench collision: scoring scenes", unit="scene", leave=False)
    for i, scene in enumerate(scenes):
        cloud, eye = scene_view(scene, rng, camera) if views <= 1 else fused_view(scene, rng, camera, views)
        keep = inside_bounds(cloud, box_min, box_max)
        inside = cloud[keep]
        eye = eye[keep] if eye.ndim == 2 else eye
        t0 = time.perf_counter()
        emb = pred.encode(inside, eye if with_origin else None)
        enc_ms.append((time.perf_counter() - t0) * 1000)
        n_points.append(len(inside))
        q = data.q[data.scene == i]
        with torch.no_grad():
            qt = torch.as_tensor(q)
            logits = pred.link_logits_q(emb, qt, None)
            p.append(torch.sigmoid(combine(pred, logits)).numpy())
            link_p.append(torch.sigmoid(logits).numpy())
        geo.append(geometric_score(q, cKDTree(cloud)) if len(cloud) else np.full(len(q), -np.inf))
    return {
        "p": np.concatenate(p),
        "link_p": np.concatenate(link_p),
        "geo": np.concatenate(geo),
        "encode_ms": np.asarray(enc_ms),
        "points": np.asarray(n_points),
    }


def query_times(pred: Predictor, data: CollisionData, repeats: int = 200) -> tuple[float, float]:
    """Median time [ms] of one query at batch 1, and of one call at batch 1000: p_collision(embedding, z) of the
    grid network (through the VAE decoder), p_collision_q(scene, q) of the local one (the labelled q of `data`)."""
    cloud = scene_cloud(data.scenes[0], np.random.default_rng(0), CameraConfig())
    if isinstance(pred, LocalPredictor):
        scene = pred.encode(cloud)
        x = torch.as_tensor(data.q[:1000])

        def call(rows):
            return pred.p_collision_q(scene, rows)
    else:
        emb = pred.encode(cloud)
        x = torch.randn(1000, pred.vae.config.latent, generator=torch.Generator().manual_seed(0))

        def call(rows):
            return pred.p_collision(emb, rows)

    one, many = [], []
    with torch.no_grad():
        for k in range(repeats):
            t0 = time.perf_counter()
            call(x[k % len(x) : k % len(x) + 1])
            one.append(time.perf_counter() - t0)
        for _ in range(5):
            t0 = time.perf_counter()
            call(x)
            many.append(time.perf_counter() - t0)
    return float(np.median(one) * 1000), float(np.median(many) * 1000)


def summarise(name: str, data: CollisionData, r: dict, threshold: float) -> dict:
    y, near = data.labels, data.near
    prec, rec = precision_recall(r["p"][near], y[near], threshold)
    prec_all, rec_all = precision_recall(r["p"], y, threshold)
    rec_88, thr_88 = recall_at_precision(r["p"][near], y[near], 0.88)
    out = {
        f"auroc_{name}": auroc(r["p"], y),
        f"auroc_near_{name}": auroc(r["p"][near], y[near]),
        f"auroc_uniform_{name}": auroc(r["p"][~near], y[~near]),
        f"geometric_auroc_{name}": auroc(r["geo"], y),
        f"geometric_auroc_near_{name}": auroc(r["geo"][near], y[near]),
        f"precision_near_{name}": prec,
        f"recall_near_{name}": rec,
        f"recall_at_precision_0.88_near_{name}": rec_88,
        f"threshold_at_precision_0.88_near_{name}": thr_88,
        f"precision_{name}": prec_all,
        f"recall_{name}": rec_all,
        f"ece_near_{name}": calibration_bins(r["p"][near], y[near])["ece"],
        f"link_auroc_{name}": {
            link: auroc(r["link_p"][:, k], data.link_labels[:, k]) for k, link in enumerate(LABEL_LINKS)
        },
        f"positive_rate_uniform_{name}": float(y[~near].mean()),
        f"positive_rate_near_{name}": float(y[near].mean()),
        f"queries_{name}": int(len(y)),
        f"scenes_{name}": len(data.scenes),
        f"cloud_points_median_{name}": float(np.median(r["points"])),
    }
    gap = -r["geo"][near]  # distance [m] from the arm's surface points to the nearest cloud point
    hidden = recall_by_bins(r["p"][near], y[near], gap, (HIDDEN_M, np.inf), threshold)
    visible = recall_by_bins(r["p"][near], y[near], gap, (0.0, HIDDEN_M), threshold)
    n_hidden, n_pos = hidden["count"][0], max(int(y[near].sum()), 1)
    missed = (r["p"][near] < threshold) & y[near]
    out.update(
        {
            f"hidden_fraction_near_{name}": n_hidden / n_pos,
            f"recall_near_hidden_{name}": hidden["recall"][0],
            f"recall_near_visible_{name}": visible["recall"][0],
            f"missed_hidden_share_near_{name}": float((gap[missed] >= HIDDEN_M).mean()) if missed.any() else 0.0,
            f"recall_by_cloud_gap_near_{name}": recall_by_bins(r["p"][near], y[near], gap, GAP_EDGES_M, threshold),
        }
    )
    return out


def outside_box(data: CollisionData, low, high) -> np.ndarray:
    """(M,) bool: the colliding near-object configurations whose every contact point (coal) with the scene lies
    outside the box [low, high] [m]: the part they hit is outside the volume the network is given."""
    out = np.zeros(len(data.labels), dtype=bool)
    low, high = np.asarray(low), np.asarray(high)
    for i, scene in enumerate(data.scenes):
        rows = np.flatnonzero((data.scene == i) & data.near & data.labels)
        if len(rows):
            points = CollisionLabeler(scene).contact_points(data.q[rows])
            out[rows] = [len(p) > 0 and not np.any(np.all((p >= low) & (p <= high), axis=1)) for p in points]
    return out


def box_split(name: str, data: CollisionData, r: dict, outside: np.ndarray, threshold: float) -> dict:
    """Near-object scores without the collisions outside the network's box, and its recall on those."""
    near, y, p = data.near, data.labels, r["p"]
    keep = near & ~outside
    prec, rec = precision_recall(p[keep], y[keep], threshold)
    return {
        f"outside_box_share_near_{name}": float(outside.sum() / max(int((near & y).sum()), 1)),
        f"recall_near_outside_box_{name}": float((p[outside] >= threshold).mean()) if outside.any() else float("nan"),
        f"auroc_near_in_box_{name}": auroc(p[keep], y[keep]),
        f"precision_near_in_box_{name}": prec,
        f"recall_near_in_box_{name}": rec,
    }

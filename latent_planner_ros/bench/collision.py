"""`bench collision`: the collision predictor on fresh scenes of the training family and of the held-out family.

Per scene one cloud from a fresh viewpoint; queries are uniform feasible configurations and configurations
near the objects, labelled exactly with coal. Reports AUROC (all and near queries), precision and recall at
the planner's threshold, a geometric reference (minus the distance from the links' surface points to the
nearest cloud point), encode and query times, a calibration plot, ROC curves and the training curve. The
near-object collisions are also split by what the camera saw of them (hidden: no cloud point within HIDDEN_M
of the arm; recall per distance bin, plotted) and by where they are (every contact outside the network's
workspace box, whose points it is never given).

The benchmark scenes (generated once per --data-dir) are labelled in --workers processes, or on Ray with
--cluster (batch/executor.py, docs/cluster.md); the scoring runs in this process (one network, one sequence of
viewpoints drawn from one generator over the scenes).
"""

from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import torch

from latent_planner_ros.batch.executor import Executor, add_executor_args, executor_config
from latent_planner_ros.bench.collision_families import extra_families, family_figures, family_markdown, score_families
from latent_planner_ros.bench.collision_models import load_predictor, predictor_box
from latent_planner_ros.bench.collision_scores import (
    BENCH_SEED,
    GAP_EDGES_M,
    HIDDEN_M,
    bench_data,
    box_split,
    evaluate_family,
    outside_box,
    query_times,
    summarise,
)
from latent_planner_ros.bench.report import bench_parser, write_report
from latent_planner_ros.models.checkpoint import CheckpointError
from latent_planner_ros.models.collision_metrics import (
    auroc,
    calibration_bins,
    precision_recall,
    roc_curve,
)
from latent_planner_ros.planning.learned_backend import CHECK_THRESHOLD


def figures(results: dict, data: dict, scores: dict, meta: dict) -> dict[str, plt.Figure]:
    figs = {}
    fig, ax = plt.subplots(figsize=(5, 5))
    ax.plot([0, 1], [0, 1], "k:", lw=1)
    for name in ("seen", "unseen"):
        near = data[name].near
        cal = calibration_bins(scores[name]["p"][near], data[name].labels[near])
        ok = np.asarray(cal["count"]) > 0
        ax.plot(
            np.asarray(cal["mean_p"])[ok],
            np.asarray(cal["positive_rate"])[ok],
            "o-",
            label=f"{name} (ECE {cal['ece']:.3f})",
        )
    ax.set(xlabel="predicted p(collision)", ylabel="observed collision rate", title="Calibration, near-object queries")
    ax.legend()
    figs["calibration"] = fig
    fig, ax = plt.subplots(figsize=(5, 5))
    for name in ("seen", "unseen"):
        near = data[name].near
        y = data[name].labels[near]
        for key, style, label in (("p", "-", "predictor"), ("geo", "--", "geometric")):
            fpr, tpr = roc_curve(scores[name][key][near], y)
            ax.plot(fpr, tpr, style, label=f"{label}, {name} (AUROC {auroc(scores[name][key][near], y):.3f})")
    ax.set(xlabel="false positive rate", ylabel="true positive rate", title="ROC, near-object queries")
    ax.legend(fontsize=8)
    figs["roc"] = fig
    fig, ax = plt.subplots(figsize=(6, 4))
    edges = list(zip(GAP_EDGES_M[:-1], GAP_EDGES_M[1:], strict=True))
    labels = [f"{100 * lo:g}-{100 * hi:g}" if np.isfinite(hi) else f">{100 * lo:g}" for lo, hi in edges]
    for k, name in enumerate(("seen", "unseen")):
        bins = results[f"recall_by_cloud_gap_near_{name}"]
        x = np.arange(len(labels)) + (k - 0.5) * 0.38
        ax.bar(x, bins["recall"], width=0.38, label=name)
        for xi, r, c in zip(x, bins["recall"], bins["count"], strict=True):
            if c:
                ax.text(xi, r + 0.01, str(c), ha="center", fontsize=7)
    ax.axvline(GAP_EDGES_M.index(HIDDEN_M) - 0.5, color="k", ls=":", lw=1)
    ax.set_xticks(np.arange(len(labels)), labels)
    ax.set(xlabel="arm to nearest cloud point [cm]", ylabel=f"recall at p >= {results['threshold']}", ylim=(0, 1.08),
           title="Colliding near-object queries: recall by what the camera saw (n on bars)")  # fmt: skip
    ax.legend(loc="lower left")
    figs["recall_by_cloud_gap"] = fig
    history = meta.get("history", [])
    if history:
        fig, ax = plt.subplots(figsize=(7, 4))
        t = [h["elapsed_s"] / 60 for h in history]
        for key in ("val_seen_auroc_near", "val_unseen_auroc_near"):
            ax.plot(t, [h.get(key, np.nan) for h in history], label=key)
        ax.set(xlabel="training time [min]", ylabel="AUROC (near queries)", title="Training curve")
        ax2 = ax.twinx()
        ax2.plot(t, [h.get("train_loss", np.nan) for h in history], "k:", label="train loss")
        ax2.set_ylabel("train loss")
        ax.legend(loc="lower right")
        figs["training"] = fig
    return figs


def markdown(results: dict, ckpt: str, threshold: float) -> str:
    rows = [
        ("AUROC, all queries", "auroc"),
        ("AUROC, near-object queries", "auroc_near"),
        ("AUROC, uniform queries", "auroc_uniform"),
        ("geometric reference AUROC, near", "geometric_auroc_near"),
        (f"precision at p >= {threshold}, near", "precision_near"),
        (f"recall at p >= {threshold}, near", "recall_near"),
        ("best recall at precision >= 0.88, near (any threshold)", "recall_at_precision_0.88_near"),
        ("... its threshold", "threshold_at_precision_0.88_near"),
        ("expected calibration error, near", "ece_near"),
        (
            f"share of hidden collisions (no cloud point within {100 * HIDDEN_M:.1f} cm of the arm), near",
            "hidden_fraction_near",
        ),
        (f"recall at p >= {threshold}, near, hidden collisions", "recall_near_hidden"),
        (f"recall at p >= {threshold}, near, the other collisions", "recall_near_visible"),
        ("share of the missed collisions that are hidden, near", "missed_hidden_share_near"),
        ("share of collisions outside the network's box (every contact), near", "outside_box_share_near"),
        (f"recall at p >= {threshold}, near, those outside the box", "recall_near_outside_box"),
        ("AUROC, near, without the collisions outside the box", "auroc_near_in_box"),
        (f"precision / recall at p >= {threshold}, near, without them", None),
        ("collision rate, uniform / near", None),
        ("scenes / queries", None),
    ]
    lines = [
        "# Collision predictor benchmark",
        "",
        f"Checkpoint `{ckpt}`. Seen = fresh scenes of the training family (boxes, cylinders, spheres, capsules,"
        " convex hulls); unseen = held-out non-convex composites (L-brackets, arches, shelves, rings, tables).",
        "Every scene is seen from a fresh random viewpoint; labels are exact (coal).",
        "",
        "| metric | seen | unseen |",
        "| --- | --- | --- |",
    ]
    for label, key in rows:
        if key:
            cells = [f"{results[f'{key}_{n}']:.3f}" for n in ("seen", "unseen")]
        elif label.startswith("collision"):
            cells = [
                f"{results[f'positive_rate_uniform_{n}']:.3f} / {results[f'positive_rate_near_{n}']:.3f}"
                for n in ("seen", "unseen")
            ]
        elif label.startswith("precision / recall"):
            cells = [
                f"{results[f'precision_near_in_box_{n}']:.3f} / {results[f'recall_near_in_box_{n}']:.3f}"
                for n in ("seen", "unseen")
            ]
        else:
            cells = [f"{results[f'scenes_{n}']} / {results[f'queries_{n}']}" for n in ("seen", "unseen")]
        lines.append(f"| {label} | {cells[0]} | {cells[1]} |")
    if "auroc_near_unseen_no_origin" in results:
        lines += [
            "",
            "Without the camera origin (the grid network's visibility channels, the local network's directions to the"
            " camera off; unseen family, near queries):"
            f" AUROC {results['auroc_near_unseen_no_origin']:.3f}, precision"
            f" {results['precision_near_unseen_no_origin']:.3f}, recall {results['recall_near_unseen_no_origin']:.3f}.",
        ]
    lines += [
        "",
        f"Encoding one cloud (the local network: indexing it): median {results['encode_ms_median']:.1f} ms"
        f" ({results['cloud_points_median_seen']:.0f} points);"
        f" one query (batch 1; the grid network through the VAE decoder): median {results['query_ms_median']:.2f} ms;"
        f" 1,000 queries: {results['query_1000_ms_median']:.1f} ms (torch threads: {results['torch_threads']}).",
        "",
    ]
    return "\n".join(lines)


def main(argv: list[str]) -> int:
    p = bench_parser("collision", __doc__)
    p.add_argument("--scenes", type=int, default=200, help="test scenes per family (default 200)")
    p.add_argument("--queries", type=int, default=100, help="uniform and near-object queries per scene (each)")
    p.add_argument("--checkpoint", type=Path, default=None, help="collision checkpoint stem (default: shipped)")
    p.add_argument("--vae", type=Path, default=None, help="VAE stem (default: the one recorded in the checkpoint)")
    p.add_argument(
        "--threshold", type=float, default=CHECK_THRESHOLD, help="decision threshold on p(collision) (the planner's)"
    )
    p.add_argument("--data-dir", type=Path, default=Path("data_cache/collision"), help="cache of benchmark scenes")
    p.add_argument("--threads", type=int, default=1, help="torch threads for timing")
    p.add_argument(
        "--families",
        default="",
        help="also score these scene families, comma-separated (data/scene_families.py; 'workcell' = every "
        "workcell family's held-out variant), each reported on its own",
    )
    p.add_argument("--family-scenes", type=int, default=50, help="test scenes per extra family (default 50)")
    add_executor_args(p, workers=1)
    args = p.parse_args(argv)
    try:
        extra = extra_families(args.families)
    except ValueError as e:
        print(f"bench collision: {e}")
        return 2
    torch.set_num_threads(args.threads)
    try:
        pred, meta = load_predictor(args.checkpoint, args.vae)
    except CheckpointError as e:
        print(f"bench collision: {e}")
        return 2
    from latent_planner_ros.models.collision_io import shipped_collision_path

    with Executor(executor_config(args)) as ex:
        data = {
            "seen": bench_data(args.data_dir, "train", "seen", args.scenes, args.queries, ex),
            "unseen": bench_data(args.data_dir, "heldout", "unseen", args.scenes, args.queries, ex),
        }
        for family in extra:  # generated here, scored by score_families below (from the cache)
            bench_data(args.data_dir, family, family, args.family_scenes, args.queries, ex)
    scores = {name: evaluate_family(pred, d, seed=BENCH_SEED + k) for k, (name, d) in enumerate(data.items())}
    results: dict = {}
    box = predictor_box(pred)
    for name in ("seen", "unseen"):
        results.update(summarise(name, data[name], scores[name], args.threshold))
        outside = outside_box(data[name], *box)
        results.update(box_split(name, data[name], scores[name], outside, args.threshold))
    if pred.uses_origin:  # the same held-out clouds, their camera origins withheld
        blind = evaluate_family(pred, data["unseen"], seed=BENCH_SEED + 1, with_origin=False)
        near, y = data["unseen"].near, data["unseen"].labels
        prec, rec = precision_recall(blind["p"][near], y[near], args.threshold)
        results.update(
            {"auroc_near_unseen_no_origin": auroc(blind["p"][near], y[near]),
             "precision_near_unseen_no_origin": prec, "recall_near_unseen_no_origin": rec}
        )  # fmt: skip
    if extra:
        results["families"] = score_families(pred, extra, args, box)
    q1, q1000 = query_times(pred, data["seen"])
    results.update(
        {
            "threshold": args.threshold,
            "encode_ms_median": float(np.median(np.concatenate([s["encode_ms"] for s in scores.values()]))),
            "query_ms_median": q1,
            "query_1000_ms_median": q1000,
            "torch_threads": torch.get_num_threads(),
            "executor": ex.name,
            "checkpoint": str(args.checkpoint or shipped_collision_path()),
            "training": {k: meta.get("training", {}).get(k) for k in ("command", "duration_s", "iterations", "scenes")},
        }
    )
    ckpt = results["checkpoint"]
    write_report(
        args.out,
        "collision",
        results,
        markdown(results, ckpt, args.threshold) + family_markdown(results.get("families", {}), args.threshold),
        figures(results, data, scores, meta) | family_figures(results.get("families", {})),
        argv,
    )
    return 0

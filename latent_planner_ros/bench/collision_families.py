"""`bench collision --families`: the collision predictor scored on each named scene family on its own (workcell
families are seen through WORKCELL_VIEWS fused views aimed at their furniture), with a table and a figure."""

from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np

from latent_planner_ros.bench.collision_models import Predictor
from latent_planner_ros.bench.collision_scores import (
    BENCH_SEED,
    WORKCELL_VIEWS,
    bench_data,
    box_split,
    evaluate_family,
    outside_box,
    summarise,
)


def extra_families(spec: str) -> list[str]:
    """The families of a comma-separated --families value ("workcell" = every workcell family, held-out);
    ValueError naming an unknown one."""
    from latent_planner_ros.data.scene_families import check_family, workcell_families

    out: list[str] = []
    for name in (s.strip() for s in spec.split(",") if s.strip()):
        if name == "workcell":
            out += [f"{f}_heldout" for f in workcell_families()]
        else:
            check_family(name)
            out.append(name)
    return list(dict.fromkeys(out))


def score_families(pred: Predictor, families: list[str], args, box: tuple[np.ndarray, np.ndarray]) -> dict:
    """Per family: near-object AUROC, precision and recall at the threshold, the geometric reference's AUROC,
    and the share of its near collisions outside the network's box, on args.family_scenes fresh scenes."""
    out = {}
    for k, family in enumerate(families):
        d = bench_data(args.data_dir, family, family, args.family_scenes, args.queries)
        tabletop = family in ("train", "heldout")
        r = evaluate_family(pred, d, seed=BENCH_SEED + 10 + k, views=1 if tabletop else WORKCELL_VIEWS)
        s = summarise(family, d, r, args.threshold)
        outside = outside_box(d, *box)
        s.update(box_split(family, d, r, outside, args.threshold))
        keys = ("auroc_near", "precision_near", "recall_near", "geometric_auroc_near", "outside_box_share_near",
                "recall_near_hidden", "positive_rate_near", "scenes", "queries")  # fmt: skip
        out[family] = {key: s[f"{key}_{family}"] for key in keys}
    return out


def family_markdown(families: dict, threshold: float) -> str:
    """A table of the extra families' scores (empty without any)."""
    if not families:
        return ""
    lines = [
        "",
        "## Per scene family",
        "",
        f"Near-object queries; precision and recall at p >= {threshold}; `outside box`: share of the collisions "
        "whose every contact lies outside the network's workspace box (it is never given those points).",
        "",
        "| family | AUROC near | precision | recall | recall, hidden | geometric AUROC | outside box | scenes |",
        "| --- | --- | --- | --- | --- | --- | --- | --- |",
    ]
    for name, f in families.items():
        lines.append(
            f"| `{name}` | {f['auroc_near']:.3f} | {f['precision_near']:.3f} | {f['recall_near']:.3f} "
            f"| {f['recall_near_hidden']:.3f} | {f['geometric_auroc_near']:.3f} | {f['outside_box_share_near']:.3f} "
            f"| {f['scenes']} |"
        )
    return "\n".join(lines) + "\n"


def family_figures(families: dict) -> dict:
    """Bars of near-object AUROC and recall per extra family, beside the geometric reference."""
    if not families:
        return {}
    names = list(families)
    fig, ax = plt.subplots(figsize=(max(6, 1.1 * len(names)), 4))
    x = np.arange(len(names))
    for k, (key, label) in enumerate(
        (("auroc_near", "AUROC near"), ("recall_near", "recall near"), ("geometric_auroc_near", "geometric AUROC"))
    ):
        ax.bar(x + (k - 1) * 0.27, [families[n][key] for n in names], width=0.27, label=label)
    ax.set_xticks(x, names, rotation=25, ha="right")
    ax.set(ylim=(0, 1.05), title="Collision predictor per scene family (near-object queries)")
    ax.grid(alpha=0.3, axis="y")
    ax.legend(fontsize=8, loc="lower left")
    return {"families": fig}

"""Markdown and figures of `bench lspp` (the layout of the seed's Table II)."""

from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np

from latent_planner_ros.bench.lspp_planners import SEED_TABLE_II


def _mean_std(rows: list[dict], key: str, scale: float = 1.0) -> str:
    a = np.array([r[key] for r in rows], dtype=float) * scale
    return f"{a.mean():.2f} ± {a.std():.2f}" if a.size else "n/a"


def markdown(results: dict) -> str:
    """Three tables (success %, planning time ms, path length) by obstacle count, ours then the seed's."""
    counts = sorted(results["obstacles"], key=int)
    names = results["planners"]
    rows = results["rows"]
    head = "| planner | " + " | ".join(counts) + " |\n|---|" + "---|" * len(counts)
    out = [
        "# LSPP on cylinder scenarios (the seed's Table II)",
        "",
        "Scenarios per obstacle count: "
        + ", ".join(f"{k}: {n}" for k, n in results["scenes_per_count"].items())
        + ". Success = TCP within 1 cm of the target and the densified path free of cylinders, table and self "
        "collision (exact meshes). Values: success with the Wilson 95% half-width; time and path length as "
        "mean ± std (path length over successful plans, TCP path / start-target distance). Seed rows are the "
        "thesis's Table II (1,000 scenarios per count, MoveIt/OMPL on another machine).",
        "",
        "## Planning success rate [%]",
        "",
        head,
    ]
    for name in names:
        cells = []
        for k in counts:
            s = results["obstacles"][k][name]
            lo, hi = s["success_ci95"]
            cells.append(f"{100 * s['success']:.1f} ± {100 * (hi - lo) / 2:.1f}")
        out.append(f"| {name} | " + " | ".join(cells) + " |")
    for name, (succ, _, _) in SEED_TABLE_II.items():
        out.append(f"| seed {name} | " + " | ".join(f"{succ[int(k) - 1]:.1f}" for k in counts if int(k) <= 5) + " |")
    out += ["", "## Planning time [ms]", "", head]
    for name in names:
        out.append(f"| {name} | " + " | ".join(
            _mean_std([r for r in rows if r["planner"] == name and r["obstacles"] == int(k)], "time_s", 1000.0)
            for k in counts) + " |")  # fmt: skip
    for name, (_, times, _) in SEED_TABLE_II.items():
        if times:
            out.append(
                f"| seed {name} | " + " | ".join(f"{times[int(k) - 1]:.1f}" for k in counts if int(k) <= 5) + " |"
            )
    out += ["", "## Path length (normalised)", "", head]
    for name in names:
        out.append(f"| {name} | " + " | ".join(
            _mean_std([r for r in rows if r["planner"] == name and r["obstacles"] == int(k) and r["success"]],
                      "path_len_norm") for k in counts) + " |")  # fmt: skip
    for name, (_, _, lengths) in SEED_TABLE_II.items():
        out.append(f"| seed {name} | " + " | ".join(f"{lengths[int(k) - 1]:.2f}" for k in counts if int(k) <= 5) + " |")
    out += [
        "",
        "## Unsafe claims and failure causes",
        "",
        "| obstacles | planner | unsafe | failures |",
        "|---|---|---|---|",
    ]
    for k in counts:
        for name in names:
            s = results["obstacles"][k][name]
            out.append(f"| {k} | {name} | {s['unsafe']} | {s['failures']} |")
    return "\n".join(out) + "\n"


def figures(results: dict) -> dict:
    """success vs obstacle count (with 95% intervals and the seed's LSPP/RRTConnect), planning time boxes."""
    counts = sorted(results["obstacles"], key=int)
    x = np.array([int(k) for k in counts])
    names = results["planners"]
    fig, ax = plt.subplots(figsize=(6.5, 4.2))
    for j, name in enumerate(names):
        s = [results["obstacles"][k][name] for k in counts]
        y = np.array([100 * v["success"] for v in s])
        lo = np.clip(y - np.array([100 * v["success_ci95"][0] for v in s]), 0.0, None)  # >= 0 despite rounding
        hi = np.clip(np.array([100 * v["success_ci95"][1] for v in s]) - y, 0.0, None)
        ax.errorbar(x + 0.04 * (j - len(names) / 2), y, yerr=[lo, hi], marker="o", capsize=3, label=name, color=f"C{j}")
        if name in SEED_TABLE_II:
            seed = [SEED_TABLE_II[name][0][int(k) - 1] for k in counts if int(k) <= 5]
            ax.plot(x[: len(seed)], seed, ls="--", color=f"C{j}", alpha=0.6, label=f"seed {name}")
    ax.set_xlabel("cylinders")
    ax.set_ylabel("planning success [%]")
    ax.set_xticks(x)
    ax.set_ylim(0, 100)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, ncol=2)
    fig2, ax2 = plt.subplots(figsize=(6.5, 4.2))
    data = [[r["time_s"] for r in results["rows"] if r["planner"] == n] for n in names]
    ax2.boxplot(data, showfliers=False)
    ax2.set_xticks(range(1, len(names) + 1), names, rotation=20)
    ax2.set_yscale("log")
    ax2.set_ylabel("planning time [s] (all obstacle counts)")
    ax2.grid(alpha=0.3, which="both")
    return {"success": fig, "time": fig2}

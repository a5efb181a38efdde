"""Statistics, markdown and figures of `bench table` (the layout of the seed's Table I)."""

from __future__ import annotations

from collections import Counter

import matplotlib.pyplot as plt
import numpy as np

from latent_planner_ros.bench.table_planners import AMP_LS_VARIANTS, SEED_TABLE_I
from latent_planner_ros.evaluation.stats import percentile, wilson_ci95


def _median(values) -> float | None:
    return percentile(values, 50)


def _std(values) -> float | None:
    a = np.asarray(values, dtype=float)
    a = a[np.isfinite(a)]
    return float(a.std()) if a.size else None


def summarise(rows: list[dict], names: list[str]) -> dict:
    """Per planner: {n, success, success_ci95, time_median_s, time_p95_s, path_len_median, path_len_std, ...}.

    Times over every attempt; path lengths (TCP path / start-goal TCP distance, joint-space and TCP lengths)
    over the successful plans only. `unsafe`: plans reported successful whose path hits the true geometry.
    """
    out: dict = {}
    for name in names:
        mine = [r for r in rows if r["planner"] == name]
        ok = [r for r in mine if r["success"]]
        n, k = len(mine), len(ok)
        times = [r["time_s"] for r in mine]
        out[name] = {
            "n": n,
            "successes": k,
            "success": k / n if n else 0.0,
            "success_ci95": list(wilson_ci95(k, n)),
            "time_median_s": _median(times),
            "time_p95_s": percentile(times, 95),
            "time_std_s": _std(times),
            "time_median_success_s": _median([r["time_s"] for r in ok]),
            "path_len_median": _median([r["path_len_norm"] for r in ok]),
            "path_len_std": _std([r["path_len_norm"] for r in ok]),
            "joint_path_median_rad": _median([r["joint_path_rad"] for r in ok]),
            "ee_path_median_m": _median([r["ee_path_m"] for r in ok]),
            "claimed": sum(r["claimed"] for r in mine),
            "unsafe": sum(r["claimed"] and bool(r["collision"]) for r in mine),
            "claimed_but_missed": sum(r["claimed"] and not r["reached"] for r in mine),
            "failures": dict(Counter(_short(r["reason"]) for r in mine if not r["claimed"]).most_common(5)),
            "speedup_vs_rrtconnect": None,
            "time_split_ms": time_split(mine),
        }
        out[name]["families"] = breakdown(mine)
    ref = out.get("rrtconnect", {}).get("time_median_s")
    for s in out.values():
        if ref and s["time_median_s"]:
            s["speedup_vs_rrtconnect"] = ref / s["time_median_s"]
    return out


def breakdown(rows: list[dict]) -> dict:
    """One planner's rows per scene family, over the problems whose goal lies inside furniture (key "inside
    goals") and over the grasp problems (key "grasp goals", planned through planning/grasp.plan_grasp):
    {group: {n, successes, success, success_ci95, time_median_s, unsafe}}; empty when the rows have a single
    family, no inside goal and no grasp (a plain tabletop set)."""
    groups: dict[str, list[dict]] = {}
    for r in rows:
        groups.setdefault(r.get("family", "unnamed"), []).append(r)
    inside = [r for r in rows if r.get("inside")]
    grasp = [r for r in rows if r.get("grasp")]
    if len(groups) < 2 and not inside and not grasp:
        return {}
    if inside:
        groups["inside goals"] = inside
    if grasp:
        groups["grasp goals"] = grasp
    out = {}
    for group, mine in sorted(groups.items()):
        n, k = len(mine), sum(r["success"] for r in mine)
        out[group] = {
            "n": n,
            "successes": k,
            "success": k / n,
            "success_ci95": list(wilson_ci95(k, n)),
            "time_median_s": _median([r["time_s"] for r in mine]),
            "unsafe": sum(r["claimed"] and bool(r["collision"]) for r in mine),
        }
    return out


SPLIT_EXCLUDED = ("total_s", "setup_s")
"""timings not in the split: the total, and AMP-LS's set-up (which overlaps its scene and check sections)"""


def time_split(rows: list[dict]) -> dict | None:
    """Where the time of typical plans goes: over one planner's rows whose time lies between its 30th and 70th
    percentile, the mean [ms] of each of its timings (AMP-LS: scene, check, ik, steps, other; OMPL: octree, ik,
    solve, simplify), of the total, and (AMP-LS) of the hard-checked states. None without timings."""
    if not rows or not any(r.get("timings") for r in rows):
        return None
    times = np.array([r["time_s"] for r in rows])
    lo, hi = np.percentile(times, [30, 70])
    typical = [r for r in rows if lo <= r["time_s"] <= hi]
    keys = sorted({k for r in typical for k in r.get("timings", {}) if k not in SPLIT_EXCLUDED})
    out = {k.removesuffix("_s"): 1e3 * float(np.mean([r["timings"].get(k, 0.0) for r in typical])) for k in keys}
    if "other_s" not in keys:  # the time outside the planner's named sections
        rest = [r["time_s"] - sum(r["timings"].get(k, 0.0) for k in keys) for r in typical]
        out["other"] = 1e3 * max(0.0, float(np.mean(rest)))
    out["total"] = 1e3 * float(np.mean([r["time_s"] for r in typical]))
    states = [r["checked_states"] for r in typical if r.get("checked_states", -1) >= 0]
    if states:
        out["checked_states"] = float(np.mean(states))
    out["plans"] = len(typical)
    return out


def _short(reason: str) -> str:
    """A failure reason without its numbers (so equal causes count together)."""
    return reason.split(" (")[0].split(":")[0][:60]


def _fmt(x, spec: str = ".2f") -> str:
    return "n/a" if x is None else format(x, spec)


def markdown(results: dict) -> str:
    """The report: the table in the seed's Table I layout, the seed's figures beside, budgets and notes."""
    s = results["scenarios"]
    tol = results["tolerance"]
    lines = [
        "# Open-loop reaching: AMP-LS vs OMPL (seed chapter 7, Table I)",
        "",
        f"Scenario set `{s['name']}` ({s['problems_run']} of {s['problems']} problems run, table "
        f"{'on' if s['table'] else 'off'}); "
        f"AMP-LS collision backend `{results['backend']}`; success = reported success, TCP within "
        f"{tol['position_m'] * 100:g} cm / {tol['orientation_deg']:g} deg (pinocchio FK) and the densified path "
        "free of the true obstacles, the table and self collision. Time: median ± std over all attempts (p95); "
        "path length: TCP path / start-goal distance, median ± std over successful plans.",
        "",
        "| planner | success | 95 % CI | planning time [s] | p95 [s] | path length | joint path [rad] "
        "| TCP path [m] | speed-up vs RRTConnect | unsafe | seed Table I |",
        "|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for name, r in results["planners"].items():
        lo, hi = r["success_ci95"]
        seed = SEED_TABLE_I.get(name)
        seed_time = f"{seed[1]:.2f} s" if seed and seed[1] is not None else "n/a"
        seed_txt = f"{seed[0]:.2f} / {seed_time} / {seed[2]:.2f}" if seed else ""
        speed = r["speedup_vs_rrtconnect"]
        lines.append(
            f"| `{name}` | {r['success']:.2f} ({r['successes']}/{r['n']}) | {lo:.2f}-{hi:.2f} "
            f"| {_fmt(r['time_median_s'], '.3f')} ± {_fmt(r['time_std_s'], '.3f')} | {_fmt(r['time_p95_s'], '.3f')} "
            f"| {_fmt(r['path_len_median'])} ± {_fmt(r['path_len_std'])} | {_fmt(r['joint_path_median_rad'])} "
            f"| {_fmt(r['ee_path_median_m'])} | {_fmt(speed, '.1f')}{'x' if speed else ''} | {r['unsafe']} "
            f"| {seed_txt} |"
        )
    lines += _family_lines(results["planners"])
    lines += _split_lines(results["planners"])
    lines += ["", "Rows:", ""]
    for name in results["planners"]:
        if name in AMP_LS_VARIANTS:
            lines.append(f"- `{name}`: {AMP_LS_VARIANTS[name].what}")
    lines += [
        "- `rrtconnect`, `lbkpiece`: first solution or timeout; `rrtstar`, `prmstar` (the seed's Lazy PRM*), "
        "`bitstar`: fixed budget (the seed reports no time for these).",
        "",
        "Seed Table I column: success / time / path length as published (Gazebo + MoveIt, a different machine "
        "and scene generator: anchors, not a like-for-like comparison). `unsafe`: plans reported successful "
        "whose path hits the true geometry (occlusion, voxelisation, a wrong prediction).",
        "",
        "Budgets: " + ", ".join(f"{k} {v}" for k, v in results["budgets"].items()),
    ]
    if results.get("amp_ls_overrides"):
        lines += ["", f"AMP-LS settings over every AMP-LS row's own (`--amp-ls-set`): {results['amp_ls_overrides']}"]
    if results.get("notes"):
        lines += ["", "Notes:", *[f"- {n}" for n in results["notes"]]]
    return "\n".join(lines)


def _family_lines(planners: dict) -> list[str]:
    """Markdown lines: success / median time / unsafe plans per scene family (and over inside goals)."""
    groups = sorted({g for r in planners.values() for g in r.get("families", {})})
    if not groups:
        return []
    lines = [
        "",
        "Per scene family: success (successes/problems), median planning time [s], unsafe plans; the row "
        "`inside goals` counts the problems whose goal lies inside furniture (a shelf slot, a bin), the row "
        "`grasp goals` the grasp problems (target set aside, pre-grasp, straight approach):",
        "",
        "| planner | " + " | ".join(f"`{g}`" for g in groups) + " |",
        "|---|" + "---|" * len(groups),
    ]
    for name, r in planners.items():
        cells = []
        for g in groups:
            f = r.get("families", {}).get(g)
            cells.append(
                ""
                if f is None
                else f"{f['success']:.2f} ({f['successes']}/{f['n']}), "
                f"{_fmt(f['time_median_s'], '.3f')} s, {f['unsafe']} unsafe"
            )
        lines.append(f"| `{name}` | " + " | ".join(cells) + " |")
    return lines


def _split_lines(planners: dict) -> list[str]:
    """Markdown lines: where the time of typical plans goes, per planner with timings."""
    lines = []
    for name, r in planners.items():
        split = r.get("time_split_ms")
        if not split:
            continue
        parts = [f"{k} {v:.0f}" for k, v in split.items() if k not in ("total", "checked_states", "plans")]
        states = f"; {split['checked_states']:.0f} states hard-checked" if "checked_states" in split else ""
        lines.append(f"- `{name}`: {split['total']:.0f} ms = {' + '.join(parts)}{states}")
    if not lines:
        return []
    head = (
        "Where the time goes: mean [ms] over each planner's plans between the 30th and 70th percentile of its "
        "planning time (AMP-LS: scene = encoding the cloud and indexing it for the geometric check, check = hard "
        "checks, ik = IK of the exact finish and goal guidance, steps = optimisation steps, other = the rest; "
        "OMPL: octree, ik = goal states, solve, simplify; each section without the sections inside it):"
    )
    return ["", head, "", *lines]


def figures(results: dict, rows: list[dict]) -> dict:
    """success vs planning time (with 95 % CIs), success bars, time distributions, path-length box plots."""
    names = list(results["planners"])
    stats = results["planners"]
    colours = {n: ("tab:blue" if n in AMP_LS_VARIANTS else "tab:orange") for n in names}
    figs = {}

    fig, ax = plt.subplots(figsize=(11, 6))
    timed = sorted((n for n in names if stats[n]["time_median_s"] is not None), key=lambda n: stats[n]["time_median_s"])
    palette = plt.get_cmap("tab20").colors
    for k, n in enumerate(timed):  # one colour per row, a legend instead of labels that overlap in clusters
        r = stats[n]
        lo, hi = r["success_ci95"]
        ax.errorbar(
            r["time_median_s"],
            r["success"],
            yerr=[[r["success"] - lo], [hi - r["success"]]],
            fmt="o" if n in AMP_LS_VARIANTS else "s",
            color=palette[k % len(palette)],
            capsize=3,
            label=f"{n}: {r['success']:.2f} in {r['time_median_s']:.3f} s",
        )
    ax.set(xscale="log", xlabel="median planning time [s]", ylabel="success rate (95 % CI)", ylim=(0, 1.05))
    ax.grid(alpha=0.3)
    ax.legend(loc="center left", bbox_to_anchor=(1.01, 0.5), fontsize=8, title="circles: AMP-LS; squares: OMPL")
    fig.tight_layout()
    figs["success_time"] = fig

    fig, ax = plt.subplots(figsize=(max(6, 0.8 * len(names)), 3.8))
    x = np.arange(len(names))
    succ = np.array([stats[n]["success"] for n in names])
    ci = np.array([stats[n]["success_ci95"] for n in names]).reshape(-1, 2)
    ax.bar(x, succ, color=[colours[n] for n in names], yerr=[succ - ci[:, 0], ci[:, 1] - succ], capsize=3)
    ax.set_xticks(x, names, rotation=35, ha="right")
    ax.set(ylabel="success rate (95 % CI)", ylim=(0, 1.05))
    figs["success"] = fig

    for key, field, ylabel, log in (
        ("times", "time_s", "planning time [s] (all attempts)", True),
        ("path_length", "path_len_norm", "TCP path / start-goal distance (successes)", False),
    ):
        fig, ax = plt.subplots(figsize=(max(6, 0.8 * len(names)), 3.8))
        data = [[r[field] for r in rows if r["planner"] == n and (key == "times" or r["success"])] for n in names]
        ax.boxplot([d if d else [np.nan] for d in data], showfliers=True)
        ax.set_xticks(np.arange(1, len(names) + 1), names, rotation=35, ha="right")
        ax.set(ylabel=ylabel, yscale="log" if log else "linear")
        ax.grid(alpha=0.3, axis="y")
        figs[key] = fig
    families = sorted({g for n in names for g in stats[n].get("families", {})})
    if families:
        figs["families"] = _family_figure(names, stats, families, colours)
    return figs


def _family_figure(names: list[str], stats: dict, families: list[str], colours: dict):
    """Grouped bars: success (95 % CI) of every planner in every scene family."""
    fig, ax = plt.subplots(figsize=(max(7, 1.1 * len(families) * max(1, len(names)) / 3), 4.2))
    width = 0.8 / max(1, len(names))
    palette = plt.get_cmap("tab20").colors
    for k, n in enumerate(names):
        fam = stats[n].get("families", {})
        x = np.arange(len(families)) + (k - (len(names) - 1) / 2) * width
        succ = np.array([fam[g]["success"] if g in fam else np.nan for g in families])
        ci = np.array([fam[g]["success_ci95"] if g in fam else [np.nan, np.nan] for g in families])
        err = np.nan_to_num(np.clip([succ - ci[:, 0], ci[:, 1] - succ], 0.0, None))  # rounding can go below 0
        ax.bar(x, np.nan_to_num(succ), width, yerr=err, capsize=2, label=n, color=palette[k % len(palette)])
    ax.set_xticks(np.arange(len(families)), families, rotation=20, ha="right")
    ax.set(ylabel="success rate (95 % CI)", ylim=(0, 1.05), title="success per scene family")
    ax.grid(alpha=0.3, axis="y")
    ax.legend(fontsize=7, ncol=2, loc="lower left")
    return fig

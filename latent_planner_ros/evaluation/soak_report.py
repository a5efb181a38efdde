"""The figures of a soak run from its time series: per node, per minute, per goal. No ROS.

A :class:`SoakLog` holds what the soak's probe and driver recorded, times [s] of simulated time from the soak's
start. :func:`summarise` turns it into the JSON-ready ``soak.json`` dict; :func:`markdown` and :func:`figures`
into the report.

Definitions:

- memory growth of a node: the least-squares slope of its RSS after the warm-up (the first
  ``warmup_share`` of the run, at most ``WARMUP_MAX_S``), in percent of the fitted RSS at the warm-up's end, per
  hour;
- tick times: the planner's status ``tick_ms`` (a value repeated by consecutive statuses counted once), p50, p99
  and max per minute of the run;
- missed control periods: a gap between consecutive ``joint_command`` stamps of g > 1.5 periods misses
  round(g / period) - 1 periods, unless it overlaps an excused interval (a joint-state pause the soak made, during
  which the planner must not command);
- contacts: onsets of ``sim/in_collision``;
- a goal's outcome, within its window (from its sending to the next goal or the end): ``refused`` when the
  planner logged or reported (``last_error``) a refusal after it was sent (the reason is that text), else
  ``reached`` or ``failed`` (the planner gave it up; the reason is its status message) by the first planner status
  saying so at least ``settle_s`` after sending, else ``timed_out`` (the next goal came first).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from latent_planner_ros.evaluation.stats import percentile
from latent_planner_ros.evaluation.trial import tick_samples

WARMUP_MAX_S = 300.0
"""[s] the warm-up excluded from the memory-growth fit is at most this long."""
REFUSAL_PREFIXES = ("goal refused", "grasp goal refused", "goal_pose refused", "grasp_pose refused")
"""The planner's texts (log and status last_error) that refuse a goal."""
ERROR_LEVEL = 40
"""rcl_interfaces/Log level of ERROR (FATAL = 50)."""
OUTCOMES = ("reached", "refused", "failed", "timed_out")


@dataclass(frozen=True)
class GoalSent:
    """A goal the soak sent: when [s], its kind (a soak_workload goal kind, or "grasp"), topic, position [m]."""

    t: float
    kind: str
    topic: str
    position: tuple[float, float, float] | None = None


@dataclass
class SoakLog:
    """What a soak recorded. Times [s] of simulated time from the soak's start.

    Attributes:
        minutes: the planned length [min]; duration_s: how long it ran [s].
        resources: (t, node, rss_mb, open fds, threads) samples.
        status: (t, state, message, last_error, tick_ms (NaN when absent)) of every planner status.
        commands: stamps of the planner's joint_command messages.
        excused: (start, end) intervals during which the planner must not command (joint-state pauses).
        contacts: onset times of sim/in_collision.
        doing: (t, command_source, p_collision, message) of every planner status: what the loop was doing.
        violations: (t, kind, detail) of commands that broke the safety invariant.
        logs: (t, node, level, text) of /rosout messages at WARN or above.
        goals: the goals sent, in order.
        plans: one-shot plans: dicts with t, tolerance, answered, success, waypoints, reason, expect.
        params: parameter changes: dicts with t, name, value, expect, successful, reason.
        crashes: nodes that ended during the run: dicts with node, t, how, tail.
        events: counts of the workload's events applied, by kind.
        command_period_s: [s] the planner's control period.
        safety: the safety monitor's summary.
    """

    minutes: float
    duration_s: float = 0.0
    resources: list = field(default_factory=list)
    status: list = field(default_factory=list)
    commands: list = field(default_factory=list)
    excused: list = field(default_factory=list)
    contacts: list = field(default_factory=list)
    doing: list = field(default_factory=list)
    violations: list = field(default_factory=list)
    logs: list = field(default_factory=list)
    goals: list = field(default_factory=list)
    plans: list = field(default_factory=list)
    params: list = field(default_factory=list)
    crashes: list = field(default_factory=list)
    events: dict = field(default_factory=dict)
    command_period_s: float = 0.1
    safety: dict = field(default_factory=dict)


def contact_context(contacts: list, doing: list, before_s: float = 1.0) -> list[dict]:
    """For each contact onset time [s]: what the planner's statuses in the before_s seconds up to it said (the
    command sources seen, the highest p(collision) of a command, the last message)."""
    out = []
    for t in contacts:
        recent = [d for d in doing if t - before_s <= d[0] <= t]
        p = []
        for d in recent:
            try:
                p.append(float(d[2]))
            except (TypeError, ValueError):
                pass
        out.append({
            "t": round(t, 2),
            "command_sources": sorted({d[1] for d in recent if d[1]}),
            "p_collision_max": round(max(p), 4) if p else None,
            "message": recent[-1][3] if recent else "",
        })  # fmt: skip
    return out


# ---------------------------------------------------------------------------------------------- per minute
def n_minutes(duration_s: float) -> int:
    return max(1, int(np.ceil(duration_s / 60.0 - 1e-9)))


def minute_ticks(status: list, duration_s: float) -> list[dict]:
    """Per minute of the run: ticks reported and tick_ms p50 / p99 / max (None without ticks)."""
    t = np.array([s[0] for s in status], dtype=float)
    ms = np.array([s[4] for s in status], dtype=float)
    out = []
    for m in range(n_minutes(duration_s)):
        inside = (t >= 60.0 * m) & (t < 60.0 * (m + 1))
        v = tick_samples(ms[inside])
        out.append(
            {
                "minute": m,
                "ticks": int(v.size),
                "p50": percentile(v, 50),
                "p99": percentile(v, 99),
                "max": float(v.max()) if v.size else None,
            }
        )
    return out


def missed_periods(commands: list, period_s: float, excused: list, duration_s: float) -> tuple[list[int], int, int]:
    """(missed periods per minute, total missed, total excused) from joint_command stamps (see the module doc)."""
    c = np.unique(np.asarray(commands, dtype=float))
    per_minute = [0] * n_minutes(duration_s)
    missed = excused_n = 0
    for a, b in zip(c[:-1], c[1:], strict=True):
        g = b - a
        if g <= 1.5 * period_s:
            continue
        n = int(round(g / period_s)) - 1
        if any(a < e1 and b > e0 for e0, e1 in excused):
            excused_n += n
            continue
        missed += n
        per_minute[min(int(a // 60.0), len(per_minute) - 1)] += n
    return per_minute, missed, excused_n


def per_minute_counts(times: list, duration_s: float) -> list[int]:
    out = [0] * n_minutes(duration_s)
    for t in times:
        out[min(max(int(t // 60.0), 0), len(out) - 1)] += 1
    return out


# ---------------------------------------------------------------------------------------------- resources
def growth_pct_per_hour(t: np.ndarray, rss: np.ndarray, warmup_s: float) -> float | None:
    """RSS growth [% / h] after the warm-up: the slope of a line fitted to the samples after warmup_s, relative to
    its value at warmup_s; None with fewer than 3 samples after the warm-up or a span under 10 s."""
    t, rss = np.asarray(t, dtype=float), np.asarray(rss, dtype=float)
    keep = t >= warmup_s
    if keep.sum() < 3 or np.ptp(t[keep]) < 10.0:
        return None
    slope, intercept = np.polyfit(t[keep], rss[keep], 1)
    base = slope * warmup_s + intercept
    return float(100.0 * slope * 3600.0 / base) if base > 0 else None


def warmup_s(duration_s: float, share: float = 0.2) -> float:
    return min(WARMUP_MAX_S, share * duration_s)


def node_resources(resources: list, duration_s: float) -> dict[str, dict]:
    """Per node: RSS [MB] first / after warm-up / last / max, growth [% / h], fds and threads first / last / max."""
    w = warmup_s(duration_s)
    out = {}
    for node in sorted({r[1] for r in resources}):
        rows = [r for r in resources if r[1] == node]
        t = np.array([r[0] for r in rows])
        rss = np.array([r[2] for r in rows])
        fds = np.array([r[3] for r in rows])
        threads = np.array([r[4] for r in rows])
        after = rss[t >= w]
        out[node] = {
            "samples": len(rows),
            "rss_mb_first": round(float(rss[0]), 1),
            "rss_mb_after_warmup": round(float(after[0]), 1) if after.size else None,
            "rss_mb_last": round(float(rss[-1]), 1),
            "rss_mb_max": round(float(rss.max()), 1),
            "rss_growth_pct_per_hour": _round(growth_pct_per_hour(t, rss, w), 2),
            "fds_first": int(fds[0]),
            "fds_last": int(fds[-1]),
            "fds_max": int(fds.max()),
            "threads_first": int(threads[0]),
            "threads_last": int(threads[-1]),
            "threads_max": int(threads.max()),
        }
    return out


def _round(v, digits: int):
    return None if v is None else round(float(v), digits)


# ---------------------------------------------------------------------------------------------- goals
def is_refusal(text: str) -> bool:
    return any(text.startswith(p) for p in REFUSAL_PREFIXES)


def classify_goals(
    goals: list[GoalSent], status: list, logs: list, duration_s: float, settle_s: float = 0.3, log_lag_s: float = 0.1
) -> list[dict]:
    """The outcome of every goal (see the module doc): dicts with t, kind, outcome, reason, after_s (time from
    sending to the outcome, None when timed out)."""
    st = sorted(status, key=lambda s: s[0])
    planner_logs = sorted((r for r in logs if r[1] == "planner" and is_refusal(r[3])), key=lambda r: r[0])
    out = []
    for i, g in enumerate(goals):
        end = goals[i + 1].t if i + 1 < len(goals) else duration_s
        before = [s[3] for s in st if s[0] < g.t]
        previous_error = before[-1] if before else ""
        outcome, reason, at = "timed_out", "", None
        refusals = [(r[0], r[3]) for r in planner_logs if g.t + log_lag_s <= r[0] < end]
        refusals += [
            (s[0], s[3]) for s in st if g.t + settle_s <= s[0] < end and is_refusal(s[3]) and s[3] != previous_error
        ]
        if refusals:
            at, reason = min(refusals)
            outcome = "refused"
        else:
            for s in st:
                if g.t + settle_s <= s[0] < end and s[1] in ("reached", "failed"):
                    outcome, at = s[1], s[0]
                    reason = "" if s[1] == "reached" else s[2]
                    break
        out.append(
            {
                "t": round(g.t, 2),
                "kind": g.kind,
                "outcome": outcome,
                "reason": reason,
                "after_s": None if at is None else round(at - g.t, 2),
                "window_s": round(end - g.t, 2),
            }
        )
    return out


def reason_class(text: str) -> str:
    """A reason without its numbers (so "a point 4 mm away" and "a point 7 mm away" count together)."""
    import re

    return re.sub(r"-?\d+(\.\d+)?", "#", text).strip()


def goal_summary(outcomes: list[dict]) -> dict:
    kinds = sorted({o["kind"] for o in outcomes})
    by_kind = {k: {x: sum(o["kind"] == k and o["outcome"] == x for o in outcomes) for x in OUTCOMES} for k in kinds}
    reasons: dict[str, int] = {}
    for o in outcomes:
        if o["outcome"] in ("refused", "failed"):
            key = f"{o['outcome']}: {reason_class(o['reason'])}"
            reasons[key] = reasons.get(key, 0) + 1
    return {
        "sent": len(outcomes),
        **{x: sum(o["outcome"] == x for o in outcomes) for x in OUTCOMES},
        "refused_without_reason": sum(o["outcome"] == "refused" and not o["reason"].strip() for o in outcomes),
        "by_kind": by_kind,
        "reasons": dict(sorted(reasons.items(), key=lambda kv: -kv[1])),
    }


# ---------------------------------------------------------------------------------------------- summary
def error_logs(logs: list) -> dict[str, list[dict]]:
    """Per node: the distinct texts logged at ERROR or above (numbers masked), with their count and first time."""
    out: dict[str, dict[str, dict]] = {}
    for t, node, level, text in logs:
        if level < ERROR_LEVEL:
            continue
        key = reason_class(text)[:300]
        entry = out.setdefault(node, {}).setdefault(key, {"text": text[:300], "count": 0, "first_t": round(t, 1)})
        entry["count"] += 1
    return {node: sorted(v.values(), key=lambda e: -e["count"]) for node, v in out.items()}


def summarise(log: SoakLog) -> dict:
    """The JSON-ready figures of a soak (the keys of soak.json)."""
    d = log.duration_s
    ticks = minute_ticks(log.status, d)
    missed_pm, missed, excused = missed_periods(log.commands, log.command_period_s, log.excused, d)
    nodes = node_resources(log.resources, d)
    growth = [v["rss_growth_pct_per_hour"] for v in nodes.values() if v["rss_growth_pct_per_hour"] is not None]
    p99s = [m["p99"] for m in ticks if m["p99"] is not None]
    outcomes = classify_goals(log.goals, log.status, log.logs, d)
    goals = goal_summary(outcomes)
    all_ticks = tick_samples(np.array([s[4] for s in log.status], dtype=float))
    errors = error_logs(log.logs)
    params_unexpected = [p for p in log.params if p.get("successful") != (p.get("expect") == "accepted")]
    plan_refusals = [
        p for p in log.plans if p.get("answered") and not p.get("success") and p.get("expect") == "refused"
    ]
    return {
        "minutes": round(d / 60.0, 3),
        "minutes_planned": log.minutes,
        "invariant_violations": len(log.violations),
        "contacts": len(log.contacts),
        "node_crashes": len(log.crashes),
        "rss_growth_pct_per_hour_max": max(growth) if growth else None,
        "tick_ms_p99_max_minute": max(p99s) if p99s else None,
        "goals_without_outcome": goals["timed_out"],
        "tick_ms_p50": percentile(all_ticks, 50),
        "tick_ms_p99": percentile(all_ticks, 99),
        "tick_ms_max": float(all_ticks.max()) if all_ticks.size else None,
        "missed_periods": missed,
        "excused_periods": excused,
        "commands": len(set(log.commands)),
        "warmup_s": warmup_s(d),
        "nodes": nodes,
        "per_minute": [
            {
                **m,
                "missed_periods": missed_pm[m["minute"]],
                "contacts": per_minute_counts(log.contacts, d)[m["minute"]],
                "violations": per_minute_counts([v[0] for v in log.violations], d)[m["minute"]],
            }
            for m in ticks
        ],
        "goals": goals,
        "goal_outcomes": outcomes,
        "plans": {
            "requested": len(log.plans),
            "answered": sum(bool(p.get("answered")) for p in log.plans),
            "succeeded": sum(bool(p.get("success")) for p in log.plans),
            "refused_as_expected": len(plan_refusals),
            "failed_or_refused_without_reason": sum(
                bool(p.get("answered")) and not p.get("success") and not str(p.get("reason", "")).strip()
                for p in log.plans
            ),
            "per_request": log.plans,
        },
        "param_changes": {
            "total": len(log.params),
            "accepted": sum(bool(p.get("successful")) for p in log.params),
            "refused": sum(not p.get("successful") for p in log.params),
            "unexpected": params_unexpected,
            "refused_without_reason": sum(not p.get("successful") and not p.get("reason") for p in log.params),
            "per_change": log.params,
        },
        "error_logs": errors,
        "error_log_count": sum(e["count"] for v in errors.values() for e in v),
        "warnings": {
            n: sum(1 for r in log.logs if r[1] == n and 30 <= r[2] < ERROR_LEVEL)
            for n in sorted({r[1] for r in log.logs})
        },
        "crashes": log.crashes,
        "violations_first": [f"{k}: {detail}" for _, k, detail in log.violations[:10]],
        "contact_times_s": [round(t, 2) for t in log.contacts[:50]],
        "contacts_context": contact_context(log.contacts[:50], log.doing),
        "events": log.events,
        "safety": log.safety,
    }


# ---------------------------------------------------------------------------------------------- report
def _f(v, spec: str = ".1f") -> str:
    return "n/a" if v is None else format(v, spec)


def markdown(res: dict) -> str:
    g = res["goals"]
    lines = [
        "# Soak: the closed loop through the ROS graph on a randomised workload",
        "",
        f"{res['minutes']:.1f} minutes of simulated time (planned {res['minutes_planned']:g}); workload seed "
        f"{res.get('seed', 'n/a')}; nodes {', '.join(res.get('nodes_run', []))}; planner collision backend "
        f"`{res.get('backend', 'n/a')}`. Events applied: "
        + ", ".join(f"{k} {v}" for k, v in res["events"].items() if not k.startswith("goal:"))
        + ".",
        "",
        "| figure | value |",
        "| --- | --- |",
        f"| safety invariant violations | {res['invariant_violations']} (commands checked: "
        f"{res['safety'].get('commands', 'n/a')}) |",
        f"| contacts (sim/in_collision onsets) | {res['contacts']} |",
        f"| node crashes | {res['node_crashes']} |",
        f"| worst RSS growth after warm-up ({res['warmup_s']:.0f} s) | {_f(res['rss_growth_pct_per_hour_max'], '.2f')} "
        "% / h |",
        f"| planner tick p50 / p99 / max | {_f(res['tick_ms_p50'])} / {_f(res['tick_ms_p99'])} / "
        f"{_f(res['tick_ms_max'])} ms |",
        f"| worst minute's tick p99 | {_f(res['tick_ms_p99_max_minute'])} ms |",
        f"| missed control periods | {res['missed_periods']} (excused during joint-state pauses: "
        f"{res['excused_periods']}; commands {res['commands']}) |",
        f"| goals sent / reached / refused / failed / timed out | {g['sent']} / {g['reached']} / {g['refused']} / "
        f"{g['failed']} / {g['timed_out']} |",
        f"| refused goals without a reason | {g['refused_without_reason']} |",
        f"| one-shot plans requested / answered / succeeded / refused as expected | {res['plans']['requested']} / "
        f"{res['plans']['answered']} / {res['plans']['succeeded']} / {res['plans']['refused_as_expected']} |",
        f"| parameter changes / accepted / refused / not as expected | {res['param_changes']['total']} / "
        f"{res['param_changes']['accepted']} / {res['param_changes']['refused']} / "
        f"{len(res['param_changes']['unexpected'])} |",
        f"| messages logged at error level | {res['error_log_count']} |",
        "",
        "## Nodes",
        "",
        "| node | RSS first / after warm-up / last / max [MB] | growth [% / h] | open fds first / last / max | "
        "threads first / last / max |",
        "| --- | --- | --- | --- | --- |",
    ]
    for name, n in res["nodes"].items():
        lines.append(
            f"| {name} | {n['rss_mb_first']} / {n['rss_mb_after_warmup']} / {n['rss_mb_last']} / {n['rss_mb_max']} | "
            f"{_f(n['rss_growth_pct_per_hour'], '.2f')} | {n['fds_first']} / {n['fds_last']} / {n['fds_max']} | "
            f"{n['threads_first']} / {n['threads_last']} / {n['threads_max']} |"
        )
    lines += ["", "## Goals by kind", "", "| kind | " + " | ".join(OUTCOMES) + " |", "| --- " * 5 + "|"]
    for kind, c in g["by_kind"].items():
        lines.append(f"| {kind} | " + " | ".join(str(c[x]) for x in OUTCOMES) + " |")
    lines += ["", "Reasons given (numbers masked):", ""]
    lines += [f"- {n} x {text}" for text, n in g["reasons"].items()] or ["- none"]
    lines += ["", "## Per minute", "", "| minute | ticks | p50 | p99 | max [ms] | missed | contacts | violations |"]
    lines.append("| --- | --- | --- | --- | --- | --- | --- | --- |")
    for m in res["per_minute"]:
        lines.append(
            f"| {m['minute']} | {m['ticks']} | {_f(m['p50'])} | {_f(m['p99'])} | {_f(m['max'])} | "
            f"{m['missed_periods']} | {m['contacts']} | {m['violations']} |"
        )
    if res.get("contacts_context"):
        lines += ["", "## Contacts: what the planner was doing in the second before each", ""]
        lines += ["| t [s] | command sources | highest p_collision | last status |", "| --- | --- | --- | --- |"]
        for c in res["contacts_context"][:20]:
            p = "-" if c["p_collision_max"] is None else f"{c['p_collision_max']:.3f}"
            lines.append(f"| {c['t']:.1f} | {', '.join(c['command_sources']) or '-'} | {p} | {c['message'][:80]} |")
    lines += ["", "## Logged at error level", ""]
    if not res["error_logs"]:
        lines.append("Nothing.")
    for node, entries in res["error_logs"].items():
        lines += [f"- {node}: {e['count']} x `{e['text'][:200]}` (first at {e['first_t']} s)" for e in entries[:10]]
    if res["crashes"]:
        lines += ["", "## Crashes", ""]
        lines += [f"- {c['node']} at {c['t']:.1f} s: {c['how']}" for c in res["crashes"]]
    return "\n".join(lines) + "\n"


def figures(log: SoakLog, res: dict) -> dict:
    """Plots over time: per-node resources, per-minute ticks and counts, goal outcomes."""
    import matplotlib.pyplot as plt

    fig_res, axes = plt.subplots(3, 1, figsize=(8, 7), sharex=True)
    for node in sorted({r[1] for r in log.resources}):
        rows = [r for r in log.resources if r[1] == node]
        t = np.array([r[0] for r in rows]) / 60.0
        for ax, k in zip(axes, (2, 3, 4), strict=True):
            ax.plot(t, [r[k] for r in rows], label=node, lw=1.0)
    for ax, label in zip(axes, ("RSS [MB]", "open fds", "threads"), strict=True):
        ax.set_ylabel(label)
        ax.grid(alpha=0.3)
        ax.axvline(res["warmup_s"] / 60.0, color="k", ls=":", lw=0.8)
    axes[0].legend(fontsize=8, loc="upper left")
    axes[0].set_title("per node (dotted: end of warm-up)")
    axes[-1].set_xlabel("simulated time [min]")

    pm = res["per_minute"]
    fig_ticks, (ax1, ax2) = plt.subplots(2, 1, figsize=(8, 5.5), sharex=True)
    x = np.array([m["minute"] for m in pm]) + 0.5
    for key, style in (("p50", "o-"), ("p99", "s-"), ("max", "^:")):
        ax1.plot(x, [np.nan if m[key] is None else m[key] for m in pm], style, label=key, ms=3)
    ax1.axhline(30.0, color="r", ls=":", lw=0.8)
    ax1.set(ylabel="planner tick [ms]")
    ax1.legend(fontsize=8)
    ax1.grid(alpha=0.3)
    width = 0.28
    for k, (key, colour) in enumerate((("missed_periods", "tab:orange"), ("contacts", "tab:red"),
                                       ("violations", "black"))):  # fmt: skip
        ax2.bar(x + (k - 1) * width, [m[key] for m in pm], width, label=key.replace("_", " "), color=colour)
    ax2.set(xlabel="simulated time [min]", ylabel="per minute")
    ax2.legend(fontsize=8)
    ax2.grid(alpha=0.3)

    fig_goals, ax = plt.subplots(figsize=(8, 3.2))
    kinds = sorted({o["kind"] for o in res["goal_outcomes"]})
    colours = {"reached": "tab:green", "refused": "tab:blue", "failed": "tab:red", "timed_out": "tab:gray"}
    for outcome, colour in colours.items():
        rows = [o for o in res["goal_outcomes"] if o["outcome"] == outcome]
        ax.scatter([o["t"] / 60.0 for o in rows], [kinds.index(o["kind"]) for o in rows], c=colour, s=14,
                   label=f"{outcome} ({len(rows)})")  # fmt: skip
    ax.set_yticks(range(len(kinds)), kinds)
    ax.set(xlabel="simulated time [min]")
    ax.set_title("goal outcomes")
    ax.legend(fontsize=7, loc="upper right", ncol=4)
    ax.grid(alpha=0.3)
    return {"resources": fig_res, "ticks": fig_ticks, "goals": fig_goals}

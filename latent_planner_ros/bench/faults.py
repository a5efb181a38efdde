"""`bench faults`: the fault-injection cases through the node suite, and the planner's tick time under load.

    python -m latent_planner_ros bench faults --out DIR [--groups inputs,scene,sim,startup] [--domain-id N]

Runs the cases of ``latent_planner_ros.bench.fault_cases`` (the same code as ``test/faults``), one suite
start-up per group, and writes ``DIR/faults.json``: ``cases`` (number run), ``survived`` (number survived),
``failed`` (names of the cases not survived), ``invariant_violations`` (commands that broke the safety
invariant; must be 0), ``load`` (the planner's tick p50/p99 [ms] from its status ``tick_ms``, commands per
second and missed control periods, at rest and while ``camera/points`` arrives at 30 Hz with 100k points),
``per_case`` (every check and note) and ``groups`` (backend, nodes, start-up and wall time); plus
``DIR/faults.md``, ``DIR/faults_ticks.png``, ``DIR/faults_cases.png`` and the nodes' output in
``DIR/faults_nodes.log``. Exit code 0 when every case survived, 1 otherwise.
"""

from __future__ import annotations

import random
import sys
import time

import numpy as np

from latent_planner_ros.bench.report import bench_parser, write_report

GROUP_NAMES = ("inputs", "scene", "sim", "startup")


def _ms(v) -> str:
    return "n/a" if v is None else f"{v:.1f}"


def markdown(res: dict) -> str:
    lines = [
        "# Fault injection through the ROS graph",
        "",
        f"{res['cases']} cases in {len(res['groups'])} groups, {res['survived']} survived; "
        f"failed: {', '.join(res['failed']) or 'none'}. Safety invariant violations: "
        f"**{res['invariant_violations']}** (every joint_command finite, inside the joint limits, within "
        f"V_MAX x {res['safety']['command_period_s']} s + {res['safety']['slack_rad']} rad of the measured state).",
        "",
        "| group | backend | nodes | start-up [s] | wall [s] | notes |",
        "| --- | --- | --- | --- | --- | --- |",
    ]
    for g in res["groups"]:
        lines.append(
            f"| {g['name']} | {g['backend'] or '-'} | {', '.join(g['nodes']) or 'one process per case'} | "
            f"{g['startup_s']:.1f} | {g['wall_s']:.1f} | {'; '.join(g['notes'])} |"
        )
    load = res.get("load")
    if load:
        b, lo = load["baseline"], load["loaded"]
        lines += [
            "",
            f"## Load: camera/points at {load['cloud_rate_hz']:g} Hz with {load['cloud_points']} points "
            f"({load['backend']} backend)",
            "",
            "| | tick p50 [ms] | tick p99 [ms] | tick max [ms] | commands/s | missed periods | longest gap [s] |",
            "| --- | --- | --- | --- | --- | --- | --- |",
        ]
        for label, d in (("normal camera (10 Hz, ~1k points)", b), ("under load", lo)):
            lines.append(
                f"| {label} | {_ms(d['tick_ms_p50'])} | {_ms(d['tick_ms_p99'])} | {_ms(d['tick_ms_max'])} | "
                f"{d['commands_per_s']:.1f} | {d['missed_periods']} | {d['command_gap_max_s']} |"
            )
        lines += [
            "",
            "`tick_ms` (the planner's status) times the optimisation step of a tick. The newest cloud is converted in "
            "the same timer callback just before it, so its cost shows in the command rate and the missed periods "
            "(a gap of 1.5 periods or more counts). The camera thread published "
            f"{lo.get('clouds_published_per_s', 'n/a')} clouds/s.",
        ]
    lines += [
        "",
        "## Cases",
        "",
        "| group | case | survived | s | failed checks / notes |",
        "| --- | --- | --- | --- | --- |",
    ]
    for c in res["per_case"]:
        failed = [k for k, ok in c["checks"].items() if not ok]
        text = ("FAILED: " + ", ".join(failed) + "; ") if failed else ""
        text += "; ".join(n for n in c["notes"] if "FAILED" not in n)[:300]
        lines.append(
            f"| {c['group']} | {c['name']} | {'yes' if c['survived'] else '**no**'} | {c['duration_s']:.1f} | "
            f"{text.replace('|', '/')} |"
        )
    return "\n".join(lines) + "\n"


def figures(res: dict, load_ticks: dict[str, list[float]]) -> dict:
    import matplotlib.pyplot as plt

    fig_ticks, ax = plt.subplots(figsize=(6.5, 3.5))
    for label, ticks in load_ticks.items():
        if ticks:
            t = np.sort(np.asarray(ticks))
            ax.step(t, np.arange(1, len(t) + 1) / len(t), where="post", label=f"{label} (n={len(t)})")
    ax.axvline(100.0, color="k", ls=":", lw=0.8)
    ax.set(xlabel="planner tick compute [ms] (period 100 ms)", ylabel="share of ticks", ylim=(0, 1.02))
    ax.set_title("planner tick time: normal camera vs 30 Hz x 100k points")
    if any(load_ticks.values()):
        ax.legend(loc="lower right", fontsize=8)
    ax.grid(alpha=0.3)
    cases = res["per_case"]
    fig_cases, ax = plt.subplots(figsize=(7, max(3.0, 0.22 * len(cases))))
    y = np.arange(len(cases))
    colours = ["tab:green" if c["survived"] else "tab:red" for c in cases]
    ax.barh(y, [c["duration_s"] for c in cases], color=colours)
    ax.set_yticks(y, [f"{c['group']}/{c['name']}" for c in cases], fontsize=7)
    ax.invert_yaxis()
    ax.set(xlabel="wall time [s] (green: survived, red: failed)")
    ax.set_title(f"{res['survived']}/{res['cases']} cases survived, {res['invariant_violations']} invariant violations")
    return {"ticks": fig_ticks, "cases": fig_cases}


def main(argv: list[str]) -> int:
    p = bench_parser("faults", __doc__.split("\n\n")[0])
    p.add_argument("--groups", default=",".join(GROUP_NAMES), help=f"comma-separated, of {', '.join(GROUP_NAMES)}")
    p.add_argument("--domain-id", type=int, metavar="N", help="ROS_DOMAIN_ID (default: a random one)")
    args = p.parse_args(argv)
    groups = [g.strip() for g in args.groups.split(",") if g.strip()]
    unknown = [g for g in groups if g not in GROUP_NAMES]
    if unknown or not groups:
        p.error(f"--groups: choose from {', '.join(GROUP_NAMES)}")

    from latent_planner_ros.bench.fault_cases import main_print, run_group, summarise
    from latent_planner_ros.evaluation.safety import SafetyConfig
    from latent_planner_ros.processes.supervisor import StartupError

    domain = args.domain_id if args.domain_id is not None else random.SystemRandom().randint(1, 101)
    log_path = args.out / "faults_nodes.log"
    args.out.mkdir(parents=True, exist_ok=True)
    log_path.write_text("")
    results, infos, t0 = [], [], time.monotonic()
    for group in groups:
        print(f"[bench faults] group {group} ...", file=sys.stderr, flush=True)
        try:
            res, info = run_group(group, log_path=log_path, domain_id=domain, progress=main_print)
        except StartupError as err:
            print(f"[bench faults] error: group {group}: {err} (node output: {log_path})", file=sys.stderr)
            return 1
        results += res
        infos.append(info)
    out = summarise(results)
    load = next((i.figures["load"] for i in infos if "load" in i.figures), None)
    load_ticks = {}
    if load is not None:
        load = {k: (dict(v) if isinstance(v, dict) else v) for k, v in load.items()}
        load_ticks = {"normal camera": load["baseline"].pop("tick_ms"), "under load": load["loaded"].pop("tick_ms")}
    safety = SafetyConfig()
    out.update(
        load=load,
        load_tick_ms_p99=None if load is None else load["loaded"]["tick_ms_p99"],
        safety={"command_period_s": safety.command_period_s, "slack_rad": safety.slack_rad},
        groups=[
            {
                "name": i.name,
                "backend": i.backend,
                "nodes": list(i.nodes),
                "notes": list(i.notes),
                "startup_s": round(i.startup_s, 1),
                "wall_s": round(i.wall_s, 1),
            }
            for i in infos
        ],
        wall_s=round(time.monotonic() - t0, 1),
        per_case=[r.to_dict() for r in results],
    )
    write_report(args.out, "faults", out, markdown(out), figures(out, load_ticks), argv)
    failed = ", ".join(out["failed"]) or "none"
    print(
        f"[bench faults] {out['survived']}/{out['cases']} cases survived (failed: {failed}), "
        f"{out['invariant_violations']} invariant violations, tick p99 under load {_ms(out['load_tick_ms_p99'])} ms, "
        f"{out['wall_s']:.0f} s",
        file=sys.stderr,
    )
    return 0 if not out["failed"] and out["invariant_violations"] == 0 else 1

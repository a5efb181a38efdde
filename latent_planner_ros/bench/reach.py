"""`bench reach`: the same static goal planned by `planner` (AMP-LS) and `ompl_planner` through GetPlan, each
plan executed by the sim.

    python -m latent_planner_ros bench reach --out DIR [--scenarios tabletop:0,shelf:0] [--backend ...]

For each SCENARIO:SEED the goal is the scenario's own target if it has a fixed one (``shelf``), else a drawn
top-down TCP pose near the objects (evaluation/reach_goals.py). Both planners start from the same reset
scene and configuration. Success: the executed arm ends within 2 cm and 20 deg of the goal without touching
an object. Writes ``DIR/reach.json`` (per planner: runs, successes, median plan time, median executed TCP
path, smallest clearance; per run: plan time, planned and executed path lengths, final errors, clearance
from ``sim/min_distance``, contacts from ``sim/in_collision``), ``DIR/reach.md`` and ``DIR/reach_runs.png``.
"""

from __future__ import annotations

import os
import sys

import numpy as np

from latent_planner_ros.bench.report import bench_parser, write_report

DEFAULT_SCENARIOS = "tabletop:0,tabletop:1,tabletop:2,shelf:0"


def _fmt(v, spec: str = ".2f", scale: float = 1.0) -> str:
    return "n/a" if v is None else format(scale * v, spec)


def markdown(res: dict) -> str:
    lines = [
        "# Static reach through the ROS graph: planner (AMP-LS) vs ompl_planner",
        "",
        f"Same goal, same start, each plan from `<node>/plan` (nav_msgs/GetPlan, tolerance "
        f"{res['plan_tolerance_m'] * 100:g} cm) executed by the sim on `joint_command`. AMP-LS collision backend "
        f"`{res['backend']}`; OMPL planner from config/ompl_planner.yaml. Success: final TCP within "
        f"{res['rule']['pos_tol_m'] * 100:g} cm and {res['rule']['ori_tol_deg']:g} deg, no arm-object contact.",
        "",
        "| planner | success | plan time, median [s] | executed TCP path, median [m] | min clearance [cm] | contacts |",
        "| --- | --- | --- | --- | --- | --- |",
    ]
    for name, s in res["planners"].items():
        lines.append(
            f"| {name} | {s['successes']}/{s['runs']} | {_fmt(s['plan_s_median'])} | "
            f"{_fmt(s['tcp_path_m_median'])} | {_fmt(s['min_distance_m'], '.1f', 100)} | {s['contacts']} |"
        )
    lines += [
        "",
        "| scenario | planner | planned | plan [s] | trajectory [s] | TCP path planned / executed [m] | "
        "final error [cm / deg] | min clearance [cm] | contacts | success |",
        "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |",
    ]
    for r in res["runs"]:
        lines.append(
            f"| {r['scenario']}:{r['seed']} | {r['planner']} | {'yes' if r['planned'] else 'no'} | "
            f"{r['plan_s']:.2f} | {_fmt(r['trajectory_s'], '.1f')} | {_fmt(r['planned_tcp_path_m'])} / "
            f"{_fmt(r['tcp_path_m'])} | {_fmt(r['final_pos_err_m'], '.1f', 100)} / "
            f"{_fmt(r['final_ori_err_deg'], '.1f')} | {_fmt(r['min_distance_m'], '.1f', 100)} | {r['contacts']} | "
            f"{'yes' if r['success'] else 'no'} |"
        )
    failed = [r for r in res["runs"] if not r["planned"]]
    if failed:
        lines += [
            "",
            "No plan: " + "; ".join(f"{r['planner']} on {r['scenario']}:{r['seed']}: {r['reason']}" for r in failed),
        ]
    return "\n".join(lines) + "\n"


def figure(runs: list[dict], planners: tuple[str, ...]):
    """Grouped bars per scenario: plan time [s], executed TCP path [m], min clearance [cm]; hatched = failure."""
    import matplotlib.pyplot as plt

    keys = list(dict.fromkeys(f"{r['scenario']}:{r['seed']}" for r in runs))
    fig, axes = plt.subplots(1, 3, figsize=(13, 3.8))
    panels = [("plan_s", 1.0, "plan time [s]"), ("tcp_path_m", 1.0, "executed TCP path [m]")]
    panels.append(("min_distance_m", 100.0, "min arm-object clearance [cm]"))
    width = 0.8 / len(planners)
    for ax, (field, scale, label) in zip(axes, panels, strict=True):
        for j, (name, colour) in enumerate(zip(planners, ("tab:blue", "tab:orange"), strict=False)):
            for i, key in enumerate(keys):
                row = next((r for r in runs if r["planner"] == name and f"{r['scenario']}:{r['seed']}" == key), None)
                if row is None or row[field] is None:
                    continue
                ax.bar(
                    i + (j - 0.5) * width,
                    scale * row[field],
                    width,
                    color=colour,
                    hatch=None if row["success"] else "//",
                    edgecolor="k",
                    label=name if i == 0 else None,
                )
        ax.set_xticks(range(len(keys)), keys, rotation=20)
        ax.set_ylabel(label)
        ax.grid(axis="y", alpha=0.3)
    axes[0].legend()
    fig.suptitle("planner vs ompl_planner through GetPlan, executed in the sim (hatched: failure)")
    fig.tight_layout()
    return fig


def parse_scenarios(text: str) -> list[tuple[str, int]]:
    """The (scenario, seed) pairs of "tabletop:0,shelf" (seed 0 when omitted); ValueError on a bad seed."""
    out = []
    for item in filter(None, (s.strip() for s in text.split(","))):
        name, _, seed = item.partition(":")
        out.append((name, int(seed) if seed else 0))
    if not out:
        raise ValueError("no scenario given")
    return out


def main(argv: list[str]) -> int:
    p = bench_parser("reach", __doc__.split("\n\n")[0])
    p.add_argument("--scenarios", default=DEFAULT_SCENARIOS, help=f"SCENARIO:SEED list (default {DEFAULT_SCENARIOS})")
    p.add_argument("--backend", choices=("geometric", "learned"), help="AMP-LS backend; default config/planner.yaml's")
    p.add_argument("--domain-id", type=int, metavar="N", help="ROS_DOMAIN_ID (default: the environment's)")
    args = p.parse_args(argv)
    try:
        scenarios = parse_scenarios(args.scenarios)
    except ValueError as err:
        p.error(f"--scenarios: {err}")
    os.environ.setdefault("MUJOCO_GL", "osmesa")

    from latent_planner_ros.evaluation.conveyor_suite import ConveyorSuite, StartupError, SuiteFailed
    from latent_planner_ros.evaluation.probes.reach_probe import ReachSession
    from latent_planner_ros.evaluation.reach import ORI_TOL_DEG, POS_TOL_M, summarise
    from latent_planner_ros.evaluation.reach_goals import choose_goal
    from latent_planner_ros.evaluation.reach_suite import PLAN_TOLERANCE_M, PLANNERS, reach_plan, run_goal
    from latent_planner_ros.processes.node_suite import SuiteError

    try:
        plan = reach_plan(args.backend)
        goals = [choose_goal(name, seed) for name, seed in scenarios]
    except (SuiteError, ValueError) as err:
        print(f"[bench reach] error: {err}", file=sys.stderr)
        return 2
    for note in plan.notes:
        print(f"[bench reach] {note}", file=sys.stderr)
    log_path = args.out / "reach_nodes.log"
    runs = []
    try:
        with ConveyorSuite(plan, log_path=log_path, domain_id=args.domain_id) as suite:
            up_s = suite.start()
            print(f"[bench reach] {', '.join(plan.nodes)} up after {up_s:.1f} s", file=sys.stderr)
            with ReachSession(args.domain_id, PLANNERS) as probe:
                for goal in goals:
                    for planner in PLANNERS:
                        row = run_goal(suite, probe, goal, planner)
                        runs.append(row)
                        print(
                            f"[bench reach] {goal.scenario}:{goal.seed} {planner}: "
                            f"{'success' if row['success'] else 'failure'}; plan {row['plan_s']:.2f} s, "
                            f"final error {_fmt(row['final_pos_err_m'], '.1f', 100)} cm, "
                            f"clearance {_fmt(row['min_distance_m'], '.1f', 100)} cm, contacts {row['contacts']}",
                            file=sys.stderr,
                        )
    except (StartupError, SuiteFailed, RuntimeError, TimeoutError) as err:
        print(f"[bench reach] error: {err} (node output: {log_path})", file=sys.stderr)
        for line in getattr(err, "tail", [])[-15:]:
            print(f"[{err.name}] {line}", file=sys.stderr)
        return 1

    results = {
        "planners": summarise(runs),
        "runs": runs,
        "goals": [g.to_dict() for g in goals],
        "backend": plan.backend,
        "nodes": list(plan.nodes),
        "notes": list(plan.notes),
        "plan_tolerance_m": PLAN_TOLERANCE_M,
        "rule": {"pos_tol_m": POS_TOL_M, "ori_tol_deg": ORI_TOL_DEG},
    }
    results = _jsonable(results)
    write_report(args.out, "reach", results, markdown(results), {"runs": figure(runs, PLANNERS)}, argv)
    return 0


def _jsonable(value):
    """numpy scalars and arrays as plain Python values, recursively."""
    if isinstance(value, dict):
        return {k: _jsonable(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_jsonable(v) for v in value]
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    return value

"""`bench conveyor`: closed-loop tracking of a moving target, N randomised trials through the node suite.

    python -m latent_planner_ros bench conveyor --trials N --out DIR [--trial-duration S] [--seed N]
        [--real-time-factor F] [--backend geometric|learned] [--only I,J] [--planner-set NAME=VALUE ...]

The same processes and path as ``demo`` (sim -> camera/points [-> scene_encoder -> scene_embedding] ->
planner -> joint_command -> sim, the planner chasing the sim's target_pose); the suite starts once and every
trial sets the sim's ``seed`` (target start, obstacle size and place) and ``scenario_overrides`` (belt speed
and direction, wrap or bounce, target size), resets the scene and tracks for ``--trial-duration`` s of
simulated time. Success (seed chapter 7, V-D): the end effector within 3 cm and 20 deg of the moving target,
then staying within for 2 s, and no contact between the arm and the scene at any time of the trial.

Writes ``DIR/conveyor.json`` (trials, success, success_ci95, collisions = trials with a contact,
tick_ms_p50/p99 over every reported tick, missed_ticks = control periods without a command, summed over
trials, and per-trial figures), ``DIR/conveyor.md`` and plots.
"""

from __future__ import annotations

import argparse
import sys

import numpy as np

from latent_planner_ros.bench.report import bench_parser, write_report
from latent_planner_ros.evaluation.stats import percentile, wilson_ci95

SPEED_RANGE = (0.03, 0.08)
"""[m/s] belt speed magnitude, drawn uniformly per trial; the direction is drawn too."""
TARGET_HALF_RANGE = (0.015, 0.035)
"""[m] half edge of the target cube, drawn uniformly per trial."""


def trial_settings(
    rng: np.random.Generator, base_seed: int, index: int, max_speed: float = SPEED_RANGE[1]
) -> tuple[int, str, dict]:
    """(sim seed, scenario_overrides YAML, the drawn values) of trial `index`; the belt speed is drawn from
    SPEED_RANGE[0] to max_speed [m/s] (the same draws as before for the default)."""
    speed = float(rng.uniform(SPEED_RANGE[0], max_speed) * rng.choice([-1.0, 1.0]))
    half = float(rng.uniform(*TARGET_HALF_RANGE))
    mode = str(rng.choice(["wrap", "bounce"]))
    drawn = {"speed": round(speed, 4), "mode": mode, "target_half_extent": round(half, 4)}
    overrides = f"{{speed: {speed:.4f}, mode: {mode}, target_half_extents: [{half:.4f}, {half:.4f}, {half:.4f}]}}"
    return base_seed * 1000 + index, overrides, drawn


def trial_indices(only: str | None, trials: int) -> list[int]:
    """The trial indices to run: 0..trials-1, or the comma-separated `only` (ValueError if malformed)."""
    if only is None:
        return list(range(trials))
    try:
        indices = [int(x) for x in only.split(",")]
    except ValueError:
        raise ValueError(f"--only takes comma-separated trial indices, got {only!r}") from None
    if any(i < 0 for i in indices) or len(set(indices)) != len(indices):
        raise ValueError(f"--only takes distinct indices >= 0, got {only!r}")
    return indices


def aggregate(rows: list[dict], ticks: list[np.ndarray]) -> dict:
    """The headline figures over trials (rows: trial_metrics dicts; ticks: per-trial tick samples [ms])."""
    n = len(rows)
    k = sum(r["success"] for r in rows)
    pooled = np.concatenate(ticks) if ticks else np.zeros(0)
    reach = [r["time_to_reach_s"] for r in rows if r["time_to_reach_s"] is not None]
    dists = [r["min_obstacle_distance_m"] for r in rows if r["min_obstacle_distance_m"] is not None]
    gaps = [r["command_gap_max_s"] for r in rows if r.get("command_gap_max_s") is not None]
    return {
        "trials": n,
        "successes": int(k),
        "success": k / n if n else 0.0,
        "success_ci95": list(wilson_ci95(k, n)),
        "reached": int(sum(r["reached"] for r in rows)),
        "tracked": int(sum(r["tracked"] for r in rows)),
        "collisions": int(sum(r["collided"] for r in rows)),
        "contact_events": int(sum(r["collisions"] for r in rows)),
        "tick_ms_p50": percentile(pooled, 50),
        "tick_ms_p99": percentile(pooled, 99),
        "tick_ms_max": float(pooled.max()) if pooled.size else None,
        "ticks_reported": int(pooled.size),
        "missed_ticks": int(sum(r["missed_ticks"] for r in rows)),
        "command_gap_max_s": max(gaps) if gaps else None,
        "time_to_reach_s_median": float(np.median(reach)) if reach else None,
        "tracking_fraction_median": float(np.median([r["tracking_fraction"] for r in rows])) if rows else None,
        "min_obstacle_distance_m": float(min(dists)) if dists else None,
    }


def _fmt(v, spec: str = ".2f") -> str:
    return "n/a" if v is None else format(v, spec)


def _cm(v) -> str:
    return "n/a" if v is None else f"{100 * v:.1f}"


def _sources(shares: dict) -> str:
    """The planner's command sources of a trial, largest share first: "servo 60%, local 40%"."""
    return ", ".join(f"{k} {v:.0%}" for k, v in sorted(shares.items(), key=lambda kv: -kv[1])) or "n/a"


def markdown(res: dict) -> str:
    lo, hi = res["success_ci95"]
    lines = [
        "# Conveyor: closed-loop tracking of a moving target through the ROS graph",
        "",
        f"{res['trials']} randomised trials of {res['trial_duration_s']:g} s simulated time each, "
        f"planner collision backend `{res['backend']}`, nodes {', '.join(res['nodes'])}, "
        f"sim real-time factor {res['real_time_factor']:g}. Success: end effector within "
        f"{res['rule']['pos_tol_m'] * 100:g} cm and {res['rule']['ori_tol_deg']:g} deg of the moving target, then "
        f"within for {res['rule']['hold_s']:g} s, and no arm contact during the trial (seed: 28/30 = 0.933).",
        "",
        "| figure | value |",
        "| --- | --- |",
        f"| success | {res['successes']}/{res['trials']} = {res['success']:.3f} (95% CI {lo:.3f}-{hi:.3f}) |",
        f"| reached / tracked 2 s | {res['reached']} / {res['tracked']} |",
        f"| trials with contact | {res['collisions']} ({res['contact_events']} contacts) |",
        f"| time to reach, median | {_fmt(res['time_to_reach_s_median'], '.1f')} s |",
        f"| share of time tracking after reach, median | {_fmt(res['tracking_fraction_median'], '.0%')} |",
        f"| min arm-object distance | {_cm(res['min_obstacle_distance_m'])} cm |",
        f"| planner tick p50 / p99 / max | {_fmt(res['tick_ms_p50'], '.1f')} / {_fmt(res['tick_ms_p99'], '.1f')} / "
        f"{_fmt(res['tick_ms_max'], '.1f')} ms |",
        f"| missed control periods | {res['missed_ticks']} (longest time between commands "
        f"{_fmt(res.get('command_gap_max_s'), '.2f')} s) |",
        "",
        "| # | seed | speed [m/s] | mode | target half edge [m] | reached [s] | tracked | contacts | "
        "min dist [cm] | tick p99 [ms] | missed | commands from | servo declined (top reasons) |",
        "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |",
    ]
    for i, t in enumerate(res["per_trial"]):
        d = t["drawn"]
        lines.append(
            f"| {i} | {t['seed']} | {d['speed']:+.3f} | {d['mode']} | {d['target_half_extent']:.3f} | "
            f"{_fmt(t['time_to_reach_s'], '.1f')} | {'yes' if t['tracked'] else 'no'} | {t['collisions']} | "
            f"{_cm(t['min_obstacle_distance_m'])} | "
            f"{_fmt(t['tick_ms_p99'], '.0f')} | {t['missed_ticks']} | {_sources(t.get('command_sources', {}))} | "
            f"{_sources(dict(list(t.get('servo_notes', {}).items())[:2]))} |"
        )
    return "\n".join(lines) + "\n"


def figures(tracks: list, rows: list[dict], ticks: list[np.ndarray], rule_tol_m: float) -> dict:
    import matplotlib.pyplot as plt

    fig_err, ax = plt.subplots(figsize=(8, 4))
    for tr, row in zip(tracks, rows, strict=True):
        ax.plot(tr.t, 100 * tr.pos_err_m, lw=0.8, color="tab:green" if row["success"] else "tab:red", alpha=0.7)
    ax.axhline(100 * rule_tol_m, color="k", ls=":", lw=0.8)
    ax.set(xlabel="simulated time [s]", ylabel="end effector to target [cm]", ylim=(0, None))
    ax.set_title("position error per trial (green: success, red: failure)")
    ax.grid(alpha=0.3)
    fig_ticks, ax = plt.subplots(figsize=(6, 3.5))
    pooled = np.concatenate(ticks) if ticks else np.zeros(0)
    if pooled.size:
        ax.hist(np.clip(pooled, 0, 300), bins=60, color="tab:blue")
    ax.axvline(100.0, color="k", ls=":", lw=0.8)
    ax.set(xlabel="planner tick compute [ms] (clipped at 300; period 100)", ylabel="ticks")
    return {"errors": fig_err, "ticks": fig_ticks}


def add_planner_set(p: argparse.ArgumentParser) -> None:
    """The --planner-set option (repeatable NAME=VALUE) of the benches that run the planner node."""
    p.add_argument(
        "--planner-set",
        action="append",
        default=[],
        metavar="NAME=VALUE",
        help="a planner parameter for this run on top of config/planner.yaml (repeatable), e.g. "
        "closed_loop.goal_lead_s=0.5",
    )


def check_planner_set(p: argparse.ArgumentParser, items: list[str]) -> None:
    """Exit through p.error when an item names no planner parameter: the node would drop it with only a warning
    in its log, and the run would not be the one asked for (malformed items are refused by the suite)."""
    from latent_planner_ros.nodes.planner_config import RANGES, READ_ONLY, PlannerNodeConfig
    from latent_planner_ros.params.specs import param_specs

    known = param_specs(PlannerNodeConfig(), RANGES, READ_ONLY)
    names = [item.partition("=")[0].strip() for item in items if "=" in item and ":=" not in item]
    unknown = [name for name in names if name and name not in known]
    if unknown:
        p.error(f"--planner-set: not a planner parameter: {', '.join(unknown)} (docs/nodes.md lists them)")


def main(argv: list[str]) -> int:
    p = bench_parser("conveyor", __doc__.split("\n\n")[0])
    p.add_argument("--trials", type=int, default=10, help="number of trials (default 10)")
    p.add_argument(
        "--max-belt-speed",
        type=float,
        default=SPEED_RANGE[1],
        metavar="V",
        help=f"each trial's belt speed is drawn from {SPEED_RANGE[0]} m/s up to this [m/s] (default {SPEED_RANGE[1]})",
    )
    p.add_argument("--trial-duration", type=float, default=15.0, metavar="S", help="simulated s per trial (15)")
    p.add_argument("--seed", type=int, default=0, help="seed of the randomisation (default 0)")
    p.add_argument("--real-time-factor", type=float, default=1.0, metavar="F", help="sim pace (default 1)")
    p.add_argument("--backend", choices=("geometric", "learned"), help="default: config/planner.yaml's")
    p.add_argument("--domain-id", type=int, metavar="N", help="ROS_DOMAIN_ID (default: the environment's)")
    p.add_argument(
        "--only",
        metavar="I,J",
        help="run only these trials (0-based indices into the sequence --seed draws), e.g. to re-run an earlier "
        "run's failures; replaces --trials",
    )
    add_planner_set(p)
    p.add_argument(
        "--record", action="store_true", help="record each trial into a rosbag2 MCAP bag, OUT/bags/trial_<index>"
    )
    args = p.parse_args(argv)
    if not SPEED_RANGE[0] <= args.max_belt_speed <= 1.0:
        p.error(f"--max-belt-speed must lie in [{SPEED_RANGE[0]}, 1.0] m/s, got {args.max_belt_speed}")
    if args.trials < 1 or args.trial_duration <= 0 or not 0.1 <= args.real_time_factor <= 10:
        p.error("--trials >= 1, --trial-duration > 0 and --real-time-factor in [0.1, 10] are required")
    try:
        indices = trial_indices(args.only, args.trials)
    except ValueError as err:
        p.error(str(err))
    check_planner_set(p, args.planner_set)

    from latent_planner_ros.evaluation.conveyor_suite import ConveyorSuite, StartupError, SuiteFailed, plan_suite
    from latent_planner_ros.evaluation.trial import SuccessRule, tick_samples, tracking, trial_metrics
    from latent_planner_ros.processes.node_suite import SuiteError

    try:
        plan = plan_suite(
            args.backend, seed=args.seed, real_time_factor=args.real_time_factor, planner_set=args.planner_set
        )
    except SuiteError as err:
        print(f"[bench conveyor] error: {err}", file=sys.stderr)
        return 2
    for note in plan.notes:
        print(f"[bench conveyor] {note}", file=sys.stderr)
    rng = np.random.default_rng(args.seed)
    rows, tracks, ticks = [], [], []
    log_path = args.out / "conveyor_nodes.log"
    try:
        with ConveyorSuite(plan, log_path=log_path, domain_id=args.domain_id) as suite:
            up_s = suite.start()
            print(f"[bench conveyor] {', '.join(plan.nodes)} up after {up_s:.1f} s", file=sys.stderr)
            draws = [trial_settings(rng, args.seed, i, args.max_belt_speed) for i in range(max(indices) + 1)]
            for n, i in enumerate(indices):
                seed, overrides, drawn = draws[i]
                if args.record:
                    from latent_planner_ros.nodes.bag_recorder import RecorderSession

                    with RecorderSession(args.out / "bags" / f"trial_{i}", args.domain_id, overwrite=True):
                        log = suite.run_trial(args.trial_duration, seed=seed, overrides=overrides)
                else:
                    log = suite.run_trial(args.trial_duration, seed=seed, overrides=overrides)
                tr = tracking(log)
                m = trial_metrics(log, track=tr)
                rows.append({"seed": seed, "drawn": drawn, **m})
                tracks.append(tr)
                ticks.append(tick_samples(log.tick_ms))
                print(
                    f"[bench conveyor] trial {n + 1}/{len(indices)} (index {i}, seed {seed}, {drawn}): "
                    f"{'success' if m['success'] else 'failure'}; reached {_fmt(m['time_to_reach_s'], '.1f')} s, "
                    f"tracked {m['tracked']}, contacts {m['collisions']}, tick p99 {_fmt(m['tick_ms_p99'], '.0f')} ms",
                    file=sys.stderr,
                )
    except (StartupError, SuiteFailed) as err:
        print(f"[bench conveyor] error: {err} (node output: {log_path})", file=sys.stderr)
        for line in getattr(err, "tail", [])[-15:]:
            print(f"[{err.name}] {line}", file=sys.stderr)
        return 1
    except (RuntimeError, TimeoutError) as err:
        print(f"[bench conveyor] error: {err} (node output: {log_path})", file=sys.stderr)
        return 1

    rule = SuccessRule()
    results = aggregate(rows, ticks)
    results.update(
        backend=plan.backend,
        configured_backend=plan.configured_backend,
        nodes=list(plan.nodes),
        notes=list(plan.notes),
        real_time_factor=plan.real_time_factor,
        trial_duration_s=args.trial_duration,
        trial_indices=indices,
        planner_set=list(args.planner_set),
        rule={"pos_tol_m": rule.pos_tol_m, "ori_tol_deg": rule.ori_tol_deg, "hold_s": rule.hold_s},
        randomisation={
            "speed_m_s": [SPEED_RANGE[0], args.max_belt_speed],
            "target_half_extent_m": list(TARGET_HALF_RANGE),
            "mode": ["wrap", "bounce"],
            "seed": "obstacle size and place, target start (sim generator)",
        },
        per_trial=rows,
    )
    write_report(args.out, "conveyor", results, markdown(results), figures(tracks, rows, ticks, rule.pos_tol_m), argv)
    lo, hi = results["success_ci95"]
    print(
        f"[bench conveyor] success {results['successes']}/{results['trials']} (95% CI {lo:.2f}-{hi:.2f}), "
        f"trials with contact {results['collisions']}, tick p50/p99 {_fmt(results['tick_ms_p50'], '.0f')}/"
        f"{_fmt(results['tick_ms_p99'], '.0f')} ms, missed periods {results['missed_ticks']}",
        file=sys.stderr,
    )
    return 0

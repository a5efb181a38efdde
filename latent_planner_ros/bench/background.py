"""`bench background`: what a background plan costs the control loop's step, on a thread and in a child process.

The closed loop takes one latent step per tick (AmpLs.step with the loop's budget: 3 iterations, 20 ms) while the
background runner plans one-shot plans back to back, as the planner node does for a still goal. Three runs of
`--ticks` ticks at 10 Hz, each on generated cluttered tabletop problems (geometric backend, seed `--seed`; not a
benchmark set): no background plan, the plans on a thread of this process (`plan_process: false`), and the plans
in a child process (`plan_process: true`, planning/plan_process.py). Reports the step time's percentiles per run
and its p99 as a ratio to the run without background plans.

    python -m latent_planner_ros bench background --out DIR [--ticks 200] [--seed 5150]
"""

from __future__ import annotations

import sys
import time

import numpy as np
from tqdm import tqdm

from latent_planner_ros.bench.report import bench_parser, write_report

MODES = ("none", "thread", "process")
PERIOD_S = 0.1
"""[s] the control period (10 Hz)"""


def _steps(stepper, problems, runner, requests, ticks: int, label: str) -> tuple[list[float], int]:
    """Step times [ms] of `ticks` ticks at 10 Hz, the runner (if any) kept busy with requests; plans finished."""
    from latent_planner_ros.planning.closed_loop import ClosedLoopConfig

    cfg = ClosedLoopConfig()
    times, done, k = [], 0, 0
    problem = problems[0]
    for tick in tqdm(range(ticks), desc=label, file=sys.stderr, leave=False):
        if runner is not None:
            if runner.poll() is not None:
                done += 1
            if not runner.busy:
                runner.submit(requests[k % len(requests)])
                k += 1
        if tick % 20 == 0:
            problem = problems[(tick // 20) % len(problems)]
        t0 = time.perf_counter()
        stepper.step(
            problem.start_q,
            problem.goal,
            problem.cloud,
            dt=PERIOD_S,
            max_iterations=cfg.max_iterations_per_tick,
            budget_s=cfg.tick_budget_ms / 1000.0,
            accepted_steps=cfg.accepted_steps_per_tick,
        )
        spent = time.perf_counter() - t0
        times.append(spent * 1000.0)
        time.sleep(max(0.0, PERIOD_S - spent))
    return times, done


def run(ticks: int, seed: int) -> dict:
    """{mode: {"step_ms": [...], "plans": n}} for MODES."""
    import torch

    from latent_planner_ros.models.vae_io import load_vae
    from latent_planner_ros.planning.amp_ls import AmpLs, AmpLsConfig
    from latent_planner_ros.planning.geometric_backend import GeometricBackend
    from latent_planner_ros.planning.plan_process import PlanProcess, PlanSpec
    from latent_planner_ros.planning.plan_runner import PlanRequest, ThreadedPlanRunner, planning_function
    from latent_planner_ros.planning.problems import cluttered_problems

    torch.set_num_threads(1)  # as the planner node
    sys.setswitchinterval(0.001)
    vae, _ = load_vae()
    config = AmpLsConfig(collision_backend="geometric")
    stepper, planner = AmpLs(vae, GeometricBackend(), config), AmpLs(vae, GeometricBackend(), config)
    stepper.warm_up()
    planner.warm_up()
    problems = cluttered_problems(12, seed)
    requests = [PlanRequest(p.start_q, p.goal, p.cloud, None, i) for i, p in enumerate(problems)]
    process = PlanProcess()
    spec = PlanSpec(config, "geometric")
    process.call(spec, None)  # the child built before its run starts
    runners = {
        "none": None,
        "thread": ThreadedPlanRunner(planning_function(planner)),
        "process": ThreadedPlanRunner(process.plan_fn(spec)),
    }
    out = {}
    try:
        for mode in MODES:
            times, plans = _steps(stepper, problems, runners[mode], requests, ticks, mode)
            out[mode] = {"step_ms": times, "plans": plans}
            runner = runners[mode]
            if runner is not None:
                while runner.busy:  # the last plan ends before the next run
                    time.sleep(0.05)
                    runner.poll()
                runner.close()
    finally:
        process.close()
    return out


def summarise(raw: dict) -> dict:
    """Percentiles [ms] per mode and the p99 ratio to the run without background plans."""
    rows = {}
    for mode, r in raw.items():
        t = np.asarray(r["step_ms"])
        p50, p90, p99 = np.percentile(t, [50, 90, 99])
        rows[mode] = {"p50_ms": p50, "p90_ms": p90, "p99_ms": p99, "max_ms": t.max(), "plans": r["plans"]}
    base = rows["none"]["p99_ms"]
    for row in rows.values():
        row["p99_vs_none"] = row["p99_ms"] / base
    return {"modes": rows, "ticks": len(raw["none"]["step_ms"])}


def markdown(res: dict) -> str:
    lines = [
        "# What a background plan costs the loop's step",
        "",
        f"{res['ticks']} ticks at 10 Hz per run; step = AmpLs.step with the closed loop's budget (geometric backend).",
        "",
        "| background plans | step p50 [ms] | p90 [ms] | p99 [ms] | max [ms] | p99 vs none | plans finished |",
        "| --- | --- | --- | --- | --- | --- | --- |",
    ]
    for mode, r in res["modes"].items():
        lines.append(
            f"| {mode} | {r['p50_ms']:.1f} | {r['p90_ms']:.1f} | {r['p99_ms']:.1f} | {r['max_ms']:.1f} | "
            f"{r['p99_vs_none']:.2f}x | {r['plans']} |"
        )
    return "\n".join(lines) + "\n"


def figure(raw: dict):
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.4, 3.6))
    for mode, r in raw.items():
        t = np.sort(r["step_ms"])
        ax.plot(t, np.arange(1, len(t) + 1) / len(t), label=f"background plans: {mode}")
    ax.set_xlabel("step time [ms]")
    ax.set_ylabel("fraction of ticks")
    ax.set_xscale("log")
    ax.grid(True, alpha=0.3)
    ax.legend()
    return fig


def main(argv: list[str]) -> int:
    p = bench_parser("background", __doc__.split("\n\n")[0])
    p.add_argument("--ticks", type=int, default=200, help="ticks per run (default 200: 20 s at 10 Hz)")
    p.add_argument("--seed", type=int, default=5150, help="seed of the generated problems (default 5150)")
    args = p.parse_args(argv)
    if args.ticks < 10:
        p.error("--ticks must be at least 10")
    raw = run(args.ticks, args.seed)
    res = summarise(raw)
    res["raw"] = {mode: r["step_ms"] for mode, r in raw.items()}
    write_report(args.out, "background", res, markdown(res), {"steps": figure(raw)}, argv)
    print(markdown(res), file=sys.stderr)
    return 0

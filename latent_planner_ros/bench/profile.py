"""`bench profile`: where a typical plan's time goes, by a sampling profiler (pyinstrument) on real problems.

Every problem is planned once without the profiler; the plans between the 30th and 70th percentile of planning
time (the typical ones: neither the straight-line successes nor the failures that run out the budget) are then
planned `--repeats` times under pyinstrument. The report gives the share of each part of the plan (the calls
made by AmpLs's plan and search loop: optimisation steps, exact finish, escape, shortcutting, scene setup, ...)
with pyinstrument's full call tree as text and as an interactive HTML page.

    python -m latent_planner_ros bench profile --out DIR [--scenarios FILE] [--scenes 60] [--repeats 3]
    python -m latent_planner_ros bench profile --out DIR --lspp-obstacles 5 [--seed 77] [--scenes 40]

The first form profiles the default AMP-LS (learned backend) on a scenario set (default: the tabletop set), the
second LSPP on generated cylinder scenarios (seed 77: not the seed of `bench lspp`'s scenarios). Times under a
sampling profiler run slower than without it; read the shares, and time with `bench table` / `bench lspp`.
"""

from __future__ import annotations

import sys
import time
from dataclasses import dataclass

import numpy as np
from tqdm import tqdm

from latent_planner_ros.bench.report import bench_parser, write_report

PARENTS = ("AmpLs._plan_once", "AmpLs._search_and_finish")
"""the frames whose direct calls are the plan's parts (the second is inside the first)"""
INTERVAL_S = 0.0002
"""pyinstrument's sampling interval [s]"""


@dataclass
class Problem:
    """One plan to make (`_plan` runs it): problem index (seeds the latent search), start (7,) [rad], goal, and
    the scene arguments of `plan` after the goal (cloud and origin, or cylinders)."""

    index: int
    start: np.ndarray
    goal: object
    scene: tuple


def _table_problems(path: str | None, n: int):
    from latent_planner_ros.bench.scenarios import DEFAULT_SET, load_scenarios
    from latent_planner_ros.bench.table import ORI_TOL_DEG, POS_TOL, TableRunner, problem_cloud
    from latent_planner_ros.planning.goal import Goal

    sset = load_scenarios(path or DEFAULT_SET)
    planner = TableRunner(["amp_ls"], "learned", sset.table).planners["amp_ls"]
    problems = []
    for i, p in enumerate(sset.problems[:n]):
        goal = Goal.from_pose(p.goal_position, p.goal_quaternion_xyzw, POS_TOL, np.radians(ORI_TOL_DEG))
        problems.append(Problem(i, np.asarray(p.start), goal, problem_cloud(p, i, sset.table)))
    return planner, problems, f"AmpLs (default, learned backend) on `{sset.name}`"


def _lspp_problems(obstacles: int, n: int, seed: int):
    from latent_planner_ros.bench.lspp import LsppRunner
    from latent_planner_ros.bench.lspp_scenarios import generate_scenarios, position_goal

    planner = LsppRunner(["lspp"]).planners["lspp"]
    scenarios = generate_scenarios([obstacles], n, seed, vae=planner.vae, progress=False)[obstacles]
    problems = [
        Problem(i, np.asarray(s.start), position_goal(np.asarray(s.target)), (np.asarray(s.cylinders, dtype=float),))
        for i, s in enumerate(scenarios)
    ]
    return planner, problems, f"LSPP (default) on {n} generated scenarios with {obstacles} cylinders (seed {seed})"


def _plan(planner, problem: Problem):
    planner.generator.manual_seed(problem.index)  # as bench table / bench lspp seed it
    return planner.plan(problem.start, problem.goal, *problem.scene)


def _name(frame) -> str:
    if frame.function == "[self]":  # pyinstrument's time spent in the parent's own lines
        return "own lines of the plan loop"
    cls = getattr(frame, "class_name", None)
    return f"{cls}.{frame.function}" if cls else frame.function


def part_times(root) -> dict[str, float]:
    """Time [s] per direct call of the PARENTS frames in pyinstrument's call tree `root`, summed over the tree
    (a PARENTS frame among the calls of another is not a part; its own calls are)."""
    out: dict[str, float] = {}
    stack = [root]
    while stack:
        frame = stack.pop()
        if _name(frame) in PARENTS:
            for child in frame.children:
                name = _name(child)
                if name in PARENTS:
                    stack.append(child)
                    continue
                out[name] = out.get(name, 0.0) + child.time
            continue
        stack.extend(frame.children)
    return dict(sorted(out.items(), key=lambda kv: -kv[1]))


def run_profile(planner, problems: list[Problem], repeats: int) -> dict:
    """Time every problem, then profile the 30-70th percentile plans `repeats` times; returns the results."""
    from pyinstrument import Profiler

    times = []
    for problem in tqdm(problems, desc="bench profile (timing)", unit="plan", dynamic_ncols=True):
        times.append(_plan(planner, problem).planning_time_s)
    t = np.asarray(times)
    lo, hi = np.percentile(t, [30, 70])
    typical = [p for p, ti in zip(problems, t, strict=True) if lo <= ti <= hi]
    profiler = Profiler(interval=INTERVAL_S)
    profiler.start()
    for _ in tqdm(range(repeats), desc="bench profile (profiling)", unit="round", dynamic_ncols=True):
        for problem in typical:
            _plan(planner, problem)
    session = profiler.stop()
    parts = part_times(session.root_frame())
    plans = repeats * len(typical)
    return {
        "plans_timed": len(problems),
        "time_median_s": float(np.median(t)),
        "typical_range_s": [float(lo), float(hi)],
        "typical_problems": [p.index for p in typical],
        "plans_profiled": plans,
        "profiled_ms_per_plan": 1000.0 * session.duration / max(plans, 1),
        "parts_ms_per_plan": {k: 1000.0 * v / max(plans, 1) for k, v in parts.items()},
        "_profiler": profiler,
    }


def markdown(results: dict, what: str) -> str:
    parts = results["parts_ms_per_plan"]
    total = max(sum(parts.values()), 1e-9)
    lo, hi = results["typical_range_s"]
    typical = len(results["typical_problems"])
    rounds = results["plans_profiled"] // max(typical, 1)
    lines = [
        "# Where a typical plan's time goes (pyinstrument)",
        "",
        f"{what}. {results['plans_timed']} plans timed without the profiler (median "
        f"{1000 * results['time_median_s']:.1f} ms); the {typical} between the 30th and 70th percentile "
        f"({1000 * lo:.1f}-{1000 * hi:.1f} ms) planned {rounds} times each under the profiler: "
        f"{results['profiled_ms_per_plan']:.1f} ms per plan there (sampling adds to it: read the shares).",
        "",
        "| part of the plan | ms per plan (profiled) | share |",
        "| --- | --- | --- |",
    ]
    lines += [f"| `{k}` | {v:.1f} | {100 * v / total:.0f} % |" for k, v in parts.items() if v / total >= 0.005]
    lines += ["", "The full call tree: `profile.txt`, and `profile.html` (open in a browser)."]
    return "\n".join(lines)


def figure(results: dict):
    import matplotlib.pyplot as plt

    parts = {k: v for k, v in results["parts_ms_per_plan"].items() if v > 0}
    names = list(parts)[:12][::-1]
    fig, ax = plt.subplots(figsize=(7, 0.4 * len(names) + 1.2))
    ax.barh(names, [parts[n] for n in names], color="tab:blue")
    ax.set_xlabel("ms per typical plan (under the profiler)")
    ax.set_title("Where a typical plan's time goes")
    fig.tight_layout()
    return fig


def main(argv: list[str]) -> int:
    p = bench_parser("profile", "Profile typical plans of AMP-LS or LSPP with pyinstrument.")
    p.add_argument("--scenarios", help="scenario set JSON (default: the shipped tabletop set)")
    p.add_argument(
        "--lspp-obstacles", type=int, default=0, help="profile LSPP on generated scenarios with this many cylinders"
    )
    p.add_argument("--seed", type=int, default=77, help="seed of the generated LSPP scenarios")
    p.add_argument("--scenes", type=int, default=60, help="problems to time")
    p.add_argument("--repeats", type=int, default=3, help="profiled rounds over the typical problems")
    args = p.parse_args(argv)
    if args.scenes < 3 or args.repeats < 1 or args.lspp_obstacles < 0:
        p.error("--scenes must be >= 3, --repeats >= 1 and --lspp-obstacles >= 0")
    try:
        import pyinstrument  # noqa: F401
    except ImportError:
        print("[bench profile] needs pyinstrument (in requirements.txt: make setup)", file=sys.stderr)
        return 2
    import torch

    torch.set_num_threads(1)
    t0 = time.perf_counter()
    if args.lspp_obstacles:
        planner, problems, what = _lspp_problems(args.lspp_obstacles, args.scenes, args.seed)
    else:
        planner, problems, what = _table_problems(args.scenarios, args.scenes)
    planner.warm_up()
    results = run_profile(planner, problems, args.repeats)
    profiler = results.pop("_profiler")
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "profile.txt").write_text(profiler.output_text(unicode=False, color=False))
    (args.out / "profile.html").write_text(profiler.output_html())
    results["what"] = what
    results["wall_s"] = time.perf_counter() - t0
    path = write_report(args.out, "profile", results, markdown(results, what), {"parts": figure(results)}, argv)
    print(f"[bench profile] wrote {path} and {args.out / 'profile.md'}")
    return 0

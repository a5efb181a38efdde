"""`bench lspp`: LSPP against classical planners on cylinder scenarios, laid out like the seed's Table II.

For each obstacle count in --obstacles (default 1-5), --scenes scenarios (default 1,000, as in the seed) are
generated as in chapter 6 IV-C (bench/lspp_scenarios.py) or read from --scenarios FILE, and every planner plans
from the same start to the same target position (1 cm, any orientation) knowing the cylinders exactly (LSPP
through its classifier, the baselines through their geometry). Success = the planner reports success, the last
state's TCP is within 1 cm of the target (pinocchio FK), and the joint path, densified to <= 1 cm of TCP motion
between checks, touches no cylinder, nor the table, nor itself (exact coal meshes).

    python -m latent_planner_ros bench lspp --out DIR [--scenes N] [--obstacles 1,2,3,4,5]
        [--planners lspp,lspp_seed,rrtconnect,potential_field] [--workers 2] [--scenarios FILE]
        [--cluster auto|ADDRESS]

Problems run in --workers processes (one torch thread each), or one Ray task each with --cluster
(batch/executor.py, docs/cluster.md); times are wall clock of each `plan` call.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
from tqdm import tqdm

from latent_planner_ros.batch.executor import Executor, ExecutorConfig, Job, add_executor_args, executor_config
from latent_planner_ros.bench.lspp_planners import ALL_PLANNERS, DEFAULT_PLANNERS, build_planners
from latent_planner_ros.bench.lspp_report import figures, markdown
from latent_planner_ros.bench.lspp_scenarios import (
    LsppScenario,
    generate_scenarios,
    load_scenarios,
    position_goal,
    save_scenarios,
)
from latent_planner_ros.bench.report import bench_parser, write_report
from latent_planner_ros.bench.table_report import summarise

SCENARIO_SEED = 2022
"""seed of the generated scenarios (the classifier's training data are seeds 1 and 2 of random pairs)"""


class LsppRunner:
    """Builds every planner once per process and runs them on one scenario at a time."""

    def __init__(self, names: list[str], threads: int = 1, classifier: str = "", lspp_overrides: dict | None = None):
        import torch

        torch.set_num_threads(threads)
        self.planners = build_planners(names, classifier or None, lspp_overrides)

    def run(self, k: int, index: int, sc: LsppScenario) -> list[dict]:
        from latent_planner_ros.data.cylinders import cylinder_scene
        from latent_planner_ros.evaluation.path_check import PathJudge
        from latent_planner_ros.planning.amp_ls import AmpLs

        start, o = np.asarray(sc.start), np.asarray(sc.cylinders, dtype=float)
        goal = position_goal(np.asarray(sc.target))
        judge = PathJudge(cylinder_scene(o))
        distance = float(np.linalg.norm(judge.panda.fk(start).translation - goal.position))
        rows = []
        for name, planner in self.planners.items():
            if isinstance(planner, AmpLs):
                planner.generator.manual_seed(index)
                result = planner.plan(start, goal, o)
            else:
                planner.set_cylinders(o)
                result = planner.plan(start, goal)
            v = judge.judge(result.q_path, goal)
            rows.append({
                "obstacles": k, "problem": index, "planner": name,
                "success": bool(result.success and v.reached and not v.collision),
                "claimed": bool(result.success), "reached": bool(v.reached), "collision": v.collision,
                "time_s": float(result.planning_time_s), "reason": result.reason,
                "pos_err_mm": 1000.0 * v.pos_err_m, "ee_path_m": v.ee_path_m, "joint_path_rad": v.joint_path_rad,
                "path_len_norm": v.ee_path_m / max(distance, 1e-6), "start_goal_distance_m": distance,
            })  # fmt: skip
        return rows


def _run_scenario(runner: LsppRunner, k: int, index: int, sc: LsppScenario) -> list[dict]:
    return runner.run(k, index, sc)


def run_lspp(
    scenarios: dict[int, list[LsppScenario]],
    names: list[str],
    workers: int = 2,
    classifier: str = "",
    lspp_overrides: dict | None = None,
    executor: Executor | None = None,
) -> list[dict]:
    """Rows of every planner on every scenario, sorted by obstacle count, scenario and planner order; one task
    per scenario on `executor` (default: `workers` local processes; each worker builds the planners once).

    lspp_overrides: AmpLsConfig fields changed in the `lspp` row (e.g. {"n_seeds": 8, "restarts": 48})."""
    lspp_overrides = lspp_overrides or {}
    tasks = [(k, i, sc) for k, scs in sorted(scenarios.items()) for i, sc in enumerate(scs)]
    job = Job(_run_scenario, LsppRunner, (names, 1, classifier, lspp_overrides))
    rows: list[dict] = []
    bar = tqdm(total=len(tasks), desc="bench lspp", unit="scenario", dynamic_ncols=True)
    for _, scenario_rows in (executor or Executor(ExecutorConfig(workers=workers))).map(job, tasks):
        rows += scenario_rows
        bar.update()
    bar.close()
    order = {n: j for j, n in enumerate(names)}
    return sorted(rows, key=lambda r: (r["obstacles"], r["problem"], order[r["planner"]]))


def _scenarios(args, counts: list[int], executor: Executor) -> dict[int, list[LsppScenario]]:
    """From --scenarios, else generated (cached in OUT/lspp_scenarios.json for the same counts, n and seed)."""
    if args.scenarios:
        have, _ = load_scenarios(args.scenarios)
        return {k: have[k][: args.scenes] for k in counts if k in have}
    cache = args.out / "lspp_scenarios.json"
    meta = {"seed": args.seed, "scenes": args.scenes, "counts": counts}
    if cache.is_file():
        have, old = load_scenarios(cache)
        if old == meta:
            return have

    scenarios = generate_scenarios(counts, args.scenes, args.seed, executor=executor)
    save_scenarios(cache, scenarios, meta)
    return scenarios


def parse_overrides(items: list[str]) -> dict:
    """["search.n_seeds=8", "checks.backtrace_keep=0.5", "lr=0.03"] -> checked AmpLsConfig overrides of the lspp
    row (dotted: a part's field, amp_ls/config.py); ValueError naming the bad item (not FIELD=VALUE, an unknown
    field, or a value the config refuses)."""
    import json

    from latent_planner_ros.planning.amp_ls import presets
    from latent_planner_ros.planning.amp_ls.config import with_overrides

    out = {}
    for item in items:
        name, sep, text = item.partition("=")
        if not sep:
            raise ValueError(f"--lspp-set {item!r}: expected FIELD=VALUE with FIELD an AmpLsConfig field")
        try:
            value = json.loads(text)
        except json.JSONDecodeError:
            value = text
        out[name.strip()] = value
    try:
        with_overrides(presets.lspp(), out)  # raises ValueError naming what the config refuses
    except (TypeError, ValueError) as err:
        raise ValueError(f"--lspp-set: {err}") from None
    return out


def main(argv: list[str]) -> int:
    p = bench_parser("lspp", __doc__)
    p.add_argument("--scenes", type=int, default=1000, help="scenarios per obstacle count (default 1000)")
    p.add_argument("--obstacles", default="1,2,3,4,5", help="obstacle counts (default 1,2,3,4,5)")
    p.add_argument("--planners", default=",".join(DEFAULT_PLANNERS), help=f"from {', '.join(ALL_PLANNERS)}")
    p.add_argument("--workers", type=int, default=2, help="processes (default 2: both cores)")
    add_executor_args(p)
    p.add_argument("--scenarios", type=Path, default=None, help="scenario file (as written to OUT/lspp_scenarios.json)")
    p.add_argument("--seed", type=int, default=SCENARIO_SEED, help="seed of generated scenarios")
    p.add_argument("--classifier", default="", help="LSPP classifier checkpoint stem (default: the shipped one)")
    p.add_argument(
        "--lspp-set",
        action="append",
        default=[],
        metavar="FIELD=VALUE",
        help="change one planner option of the lspp row (repeatable; dotted: a part's field), "
        "e.g. --lspp-set search.n_seeds=8 --lspp-set search.restarts=48",
    )
    args = p.parse_args(argv)
    try:
        overrides = parse_overrides(args.lspp_set)
        counts = sorted({int(c) for c in args.obstacles.split(",") if c.strip()})
        if not counts or min(counts) < 1:
            raise ValueError("obstacle counts must be integers >= 1")
        names = [n.strip() for n in args.planners.split(",") if n.strip()]
        unknown = [n for n in names if n not in ALL_PLANNERS]
        if unknown or not names:
            raise ValueError(f"unknown planner(s) {unknown}; choose from {', '.join(ALL_PLANNERS)}")
        if args.scenes < 1:
            raise ValueError("--scenes must be >= 1")
    except ValueError as err:
        print(f"bench lspp: {err}", file=sys.stderr)
        return 2
    args.out.mkdir(parents=True, exist_ok=True)
    with Executor(executor_config(args)) as ex:
        scenarios = _scenarios(args, counts, ex)
        rows = run_lspp(scenarios, names, classifier=args.classifier, lspp_overrides=overrides, executor=ex)
    results = {
        "obstacles": {str(k): summarise([r for r in rows if r["obstacles"] == k], names) for k in sorted(scenarios)},
        "scenes_per_count": {str(k): len(v) for k, v in scenarios.items()},
        "planners": names,
        "tolerance": {"position_m": 0.01, "orientation": "any"},
        "scenario_seed": args.seed,
        "lspp_overrides": overrides,
        "workers": args.workers,
        "executor": ex.name,
        "cluster": args.cluster,
        "rows": rows,
    }
    write_report(args.out, "lspp", results, markdown(results), figures(results), argv)
    return 0

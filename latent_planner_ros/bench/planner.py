"""`bench planner`: AMP-LS open-loop success and time, and closed-loop tick timings.

Free-space problems (random feasible start and goal configurations) and cluttered problems (random tabletop
scenes of the held-out family, one virtual camera view each; the planner sees only the cloud). Open loop:
success = the returned path ends within tolerance (pinocchio FK) and no densified segment of it collides
with the scene's obstacles (exact coal check). Closed loop: `step` ticks against a perfectly tracking
arm; tick times are the planner's compute per tick with the configured step budget.
"""

from __future__ import annotations

import time

import matplotlib.pyplot as plt
import numpy as np
import torch
from tqdm import tqdm

from latent_planner_ros.bench.report import bench_parser, write_report
from latent_planner_ros.evaluation.stats import wilson_ci95
from latent_planner_ros.models.checkpoint import CheckpointError
from latent_planner_ros.models.vae_io import load_vae
from latent_planner_ros.planning.amp_ls import AmpLs, AmpLsConfig
from latent_planner_ros.planning.backends import make_backend
from latent_planner_ros.planning.closed_loop import ClosedLoopConfig, ClosedLoopController
from latent_planner_ros.planning.plan_runner import DeferredPlanRunner, planning_function
from latent_planner_ros.planning.problems import Problem, cluttered_problems, free_space_problems, path_collides
from latent_planner_ros.robot.panda import load_panda

FREE_SEED, CLUTTER_SEED = 2000, 3000
"""Seeds of the benchmark problems (tests use other seeds; training never sees these scenes)."""


def reached(q: np.ndarray, problem: Problem, use_orientation: bool = True) -> tuple[bool, float, float]:
    """(within tolerance, position error [m], orientation error [rad]) of q's TCP pose (pinocchio FK)."""
    tf = load_panda().fk(q)
    pe = float(np.linalg.norm(tf.translation - problem.goal.position))
    cos = (np.trace(tf.rotation.T @ problem.goal.rotation) - 1.0) / 2.0
    oe = float(np.arccos(np.clip(cos, -1.0, 1.0)))
    return pe < problem.goal.pos_tol and (oe < problem.goal.ori_tol or not use_orientation), pe, oe


def open_loop(planner: AmpLs, problems: list[Problem], label: str) -> dict:
    rows = []
    for pr in tqdm(problems, desc=f"open loop, {label}", dynamic_ncols=True):
        res = planner.plan(pr.start_q, pr.goal, pr.cloud if len(pr.cloud) else None, pr.origin)
        ok, pe, oe = reached(res.q_path[-1], pr, planner.config.use_orientation)
        collided = path_collides(pr, res.q_path)
        rows.append((ok and not collided, collided, res.planning_time_s, pe, res.reason))
    success = [r[0] for r in rows]
    k = int(np.sum(success))
    return {
        "problems": len(rows),
        "success": k / len(rows),
        "success_ci95": wilson_ci95(k, len(rows)),
        "collisions": int(np.sum([r[1] for r in rows])),
        "time_ms": [1000.0 * r[2] for r in rows],
        "open_loop_ms_median": float(1000.0 * np.median([r[2] for r in rows])),
        "open_loop_ms_median_success": float(1000.0 * np.median([r[2] for r in rows if r[0]] or [np.nan])),
        "final_pos_err_mm_median": float(1000.0 * np.median([r[3] for r in rows])),
        "failures": sorted({r[4] for r in rows if not r[0]}),
    }


def _scene(planner: AmpLs, pr: Problem):
    """The problem's scene as the node hands it to the closed loop: the cloud (geometric backend) or its
    embedding (learned backend, encoded once with the camera origin, as the scene_encoder node does)."""
    backend = planner.backend
    if not planner.config.use_collision:
        return None
    backend.set_scene(pr.cloud, pr.origin)
    return backend.embedding if backend.mode == "learned" else pr.cloud


def closed_loop(planner: AmpLs, problems: list[Problem], label: str, ticks: int, loop: ClosedLoopConfig) -> dict:
    """Closed-loop success (within tolerance by the end, no collision) and tick timings [ms], each tick the planner
    node's ClosedLoopController against a perfectly tracking arm in simulated time (`loop`: its steps per tick,
    time budget and background plans; a background plan, run by a DeferredPlanRunner on a planner instance of its
    own, arrives as many ticks later as it took; its time is not counted in the tick's)."""
    period = 1.0 / loop.rate_hz
    plan_planner = AmpLs(planner.vae, planner.backend, planner.config)  # the node's second instance
    tick_ms, successes, collisions, sources = [], 0, 0, {"plan": 0, "local": 0, "wait": 0, "hold": 0}
    plans = {"requested": 0, "followed": 0, "failed": 0, "dropped": 0}
    for pr in tqdm(problems, desc=f"closed loop, {label}", dynamic_ncols=True):
        runner = DeferredPlanRunner(planning_function(plan_planner))
        controller = ClosedLoopController(planner, loop, runner)
        planner.reset()
        scene = _scene(planner, pr)
        q = pr.start_q.copy()
        path = [q]
        controller.set_joint_state(q, 0.0)
        controller.set_scene(scene, 0.0, cloud=pr.cloud, eyes=pr.origin)  # the camera, as the node has it
        controller.set_goal(pr.goal, 0.0)
        for k in range(ticks):
            now = k * period
            controller.set_joint_state(q, now)
            controller.set_scene(scene, now)
            spent = runner.spent_s
            t0 = time.perf_counter()
            out = controller.tick(now)
            tick_ms.append(1000.0 * (time.perf_counter() - t0 - (runner.spent_s - spent)))
            sources[out.values.get("command_source", "local")] += 1
            if out.command is not None:
                q = out.command
            path.append(q)
            if out.state == "failed" or (out.state == "reached" and reached(q, pr, planner.config.use_orientation)[0]):
                break
        if controller.follower is not None:
            plans = {key: plans.get(key, 0) + n for key, n in controller.follower.plans.items()}
        collided = path_collides(pr, np.array(path))
        collisions += collided
        successes += reached(q, pr, planner.config.use_orientation)[0] and not collided
    n = len(problems)
    return {
        "tick_ms": tick_ms,
        "tick_ms_p50": float(np.percentile(tick_ms, 50)),
        "tick_ms_p99": float(np.percentile(tick_ms, 99)),
        "closed_loop_success": successes / n,
        "closed_loop_success_ci95": wilson_ci95(successes, n),
        "closed_loop_collisions": collisions,
        "command_sources": sources,
        "background_plans": plans,
    }


def figures(results: dict) -> dict:
    fig, axes = plt.subplots(1, 2, figsize=(10, 3.6))
    for key, colour in (("free", "tab:blue"), ("cluttered", "tab:orange")):
        r = results[key]
        axes[0].hist(r["time_ms"], bins=30, alpha=0.6, color=colour, label=f"{key} ({r['success']:.0%} success)")
        axes[1].hist(r["tick_ms"], bins=30, alpha=0.6, color=colour, label=key)
    axes[0].set(xlabel="open-loop planning time [ms]", ylabel="problems", title="open loop")
    axes[1].set(xlabel="closed-loop tick [ms]", ylabel="ticks", title="closed loop (100 ms period)")
    for ax in axes:
        ax.legend()
    fig.tight_layout()
    return {"times": fig}


def main(argv: list[str]) -> int:
    p = bench_parser("planner", __doc__)
    p.add_argument("--problems", type=int, default=50, help="problems per setting (free, cluttered)")
    p.add_argument("--backend", default="learned", help="collision backend: learned, geometric or none")
    p.add_argument("--ticks", type=int, default=100, help="closed-loop ticks per problem (at most)")
    p.add_argument("--threads", type=int, default=1, help="torch threads")
    p.add_argument("--collision-checkpoint", default="", help="learned backend weights (stem; default: shipped)")
    p.add_argument(
        "--no-local-baseline", action="store_true", help="skip the closed loop with local steps only (follow_plans off)"
    )
    args = p.parse_args(argv)
    torch.set_num_threads(args.threads)
    config = AmpLsConfig(collision_backend=args.backend)
    try:
        vae, _ = load_vae()
        backend = make_backend(args.backend, args.collision_checkpoint)
    except CheckpointError as err:
        raise SystemExit(f"bench planner: {err}") from None
    planner = AmpLs(vae, backend, config)
    problems = {
        "free": free_space_problems(args.problems, FREE_SEED),
        "cluttered": cluttered_problems(args.problems, CLUTTER_SEED),
    }
    results: dict = {
        "backend": args.backend,
        "collision_checkpoint": args.collision_checkpoint or "shipped",
        "config": config.to_dict(),
    }
    local_only = ClosedLoopConfig(follow_plans=False)
    for key, probs in problems.items():
        results[key] = open_loop(planner, probs, key)
        results[key].update(closed_loop(planner, probs, key, args.ticks, ClosedLoopConfig()))
        if not args.no_local_baseline:
            local = closed_loop(planner, probs, f"{key}, local steps only", args.ticks, local_only)
            results[key]["local_only"] = {k: v for k, v in local.items() if k != "tick_ms"}
    all_ticks = results["free"]["tick_ms"] + results["cluttered"]["tick_ms"]
    results["tick_ms_p50"] = float(np.percentile(all_ticks, 50))
    results["tick_ms_p99"] = float(np.percentile(all_ticks, 99))
    results["open_loop_ms_median"] = float(np.median(results["free"]["time_ms"] + results["cluttered"]["time_ms"]))
    md = [
        "# AMP-LS planner benchmark",
        "",
        f"Backend `{args.backend}` (collision weights: {results['collision_checkpoint']}), "
        f"{args.problems} free-space and {args.problems} cluttered problems "
        "(held-out scene family), tolerance 1 cm / 15 deg.",
        "",
        "| setting | open-loop success | 95 % CI | collisions | median time [ms] | closed-loop success | 95 % CI "
        "| closed-loop collisions | local steps only | tick p50 [ms] | tick p99 [ms] |",
        "|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for key in problems:
        r = results[key]
        lo, hi = r["success_ci95"]
        clo, chi = r["closed_loop_success_ci95"]
        local = f"{r['local_only']['closed_loop_success']:.0%}" if "local_only" in r else "-"
        md.append(
            f"| {key} | {r['success']:.0%} | {lo:.0%}-{hi:.0%} | {r['collisions']} | {r['open_loop_ms_median']:.0f} "
            f"| {r['closed_loop_success']:.0%} | {clo:.0%}-{chi:.0%} | {r['closed_loop_collisions']} | {local} "
            f"| {r['tick_ms_p50']:.1f} | {r['tick_ms_p99']:.1f} |"
        )
    md += [
        "",
        f"All ticks: p50 {results['tick_ms_p50']:.1f} ms, p99 {results['tick_ms_p99']:.1f} ms (the closed loop as "
        "the node runs it: background plans followed, local steps otherwise; a plan's own time is not a tick's).",
        "",
        "| setting | ticks following a plan | local steps | holding for a plan | plans requested | followed "
        "| failed | dropped |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for key in problems:
        src, pl = results[key]["command_sources"], results[key]["background_plans"]
        md.append(
            f"| {key} | {src['plan']} | {src['local']} | {src['wait']} | {pl['requested']} | {pl['followed']} "
            f"| {pl['failed']} | {pl['dropped']} |"
        )
    write_report(args.out, "planner", results, "\n".join(md), figures(results), argv)
    return 0

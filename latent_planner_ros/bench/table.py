"""`bench table`: AMP-LS against the OMPL planners on a scenario set, laid out like the seed's Table I.

Every planner gets the same problems, the same point cloud per problem (rendered once by the virtual depth
camera from the problem's viewpoint; planners never see the true geometry) and the same tolerance. A plan
succeeds when the planner reports success, its last state's TCP is within 1 cm and 15 deg of the goal
(pinocchio FK), and the joint path, densified to <= 1 cm of TCP motion and <= 0.02 rad per joint between
checks, is free of the TRUE obstacles (exact coal meshes), the table and self collision.

A grasp problem (`"grasp": true`) is planned by every planner through planning/grasp.plan_grasp (the target's
points set aside, a plan to the pre-grasp `approach_m` back, default 8 cm, then a straight checked approach); the
judge keeps the target object among the true obstacles: fingers around it are fine, a finger touching it is a
collision.

    python -m latent_planner_ros bench table --out bench_out/table [--scenarios FILE] [--scenes N]
        [--planners amp_ls,rrtconnect,...] [--backend auto|learned|geometric] [--workers 2] [--minutes M]
        [--cluster auto|ADDRESS]

Problems run in `--workers` processes (one torch thread each), or one Ray task each with --cluster
(batch/executor.py, docs/cluster.md); a planner's time is the wall-clock time of its `plan` call. Budgets: see
bench/table_planners.py.
"""

from __future__ import annotations

import os
import sys
import time
from pathlib import Path

import numpy as np
from tqdm import tqdm

from latent_planner_ros.batch.executor import Executor, ExecutorConfig, Job, add_executor_args, executor_config
from latent_planner_ros.bench.report import bench_parser, write_report
from latent_planner_ros.bench.scenarios import DEFAULT_SET, ScenarioError, ScenarioProblem, load_scenarios
from latent_planner_ros.bench.table_planners import (
    AMP_LS_VARIANTS,
    amp_ls_config,
    budgets,
    ompl_config,
    parse_overrides,
    parse_planners,
)
from latent_planner_ros.bench.table_report import figures, markdown, summarise
from latent_planner_ros.data.camera import CameraConfig, planning_crop, sample_camera_pose
from latent_planner_ros.planning.collision_backend import BackendDefaults

POS_TOL = 0.01
"""position tolerance of success [m] (the seed's 1 cm)"""
ORI_TOL_DEG = 15.0
"""orientation tolerance of success [deg] (the seed's 15 deg)"""
CLOUD_SEED = 9000
"""seeds the viewpoint and depth noise of problems without a camera"""


def problem_cloud(
    problem: ScenarioProblem, index: int, table: bool, camera: CameraConfig | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """The point cloud (N, 3) float32 [m] in `world` the problem's depth cameras see of its true obstacles, each
    view cropped to the sim camera's box (`planning_crop`: the arm's reach) and the views fused, and where each
    point was seen from: the optical centre (3,) [m] of a single camera, or (N, 3) float32, one per point, when
    the problem has several cameras.

    The viewpoints are the problem's cameras, else one drawn from the camera ranges with a seed from `index`;
    each view's depth noise is seeded by its camera's seed (else `index`), so the cloud is the same on every run.
    """
    cfg = camera or CameraConfig()
    if not problem.cameras:
        rng = np.random.default_rng(np.random.SeedSequence([CLOUD_SEED, index]))
        return _view_cloud(problem, table, cfg, sample_camera_pose(rng, cfg), rng)
    views = []
    for spec in problem.cameras:
        rng = np.random.default_rng(index if spec.seed is None else spec.seed)
        views.append(_view_cloud(problem, table, cfg, spec.pose(), rng))
    if len(views) == 1:
        return views[0]
    cloud = np.concatenate([v[0] for v in views]).astype(np.float32)
    origins = np.concatenate([np.repeat(v[1][None].astype(np.float32), len(v[0]), 0) for v in views])
    return cloud, origins.reshape(-1, 3)


def _view_cloud(
    problem: ScenarioProblem, table: bool, cfg: CameraConfig, pose: np.ndarray, rng: np.random.Generator
) -> tuple[np.ndarray, np.ndarray]:
    """The cropped cloud (N, 3) float32 [m] of one view from camera-to-world `pose` (4, 4), and its eye (3,)."""
    from latent_planner_ros.data.render import add_depth_noise, crop, depth_to_points, render_depth

    if not problem.obstacles and not table:
        return np.zeros((0, 3), dtype=np.float32), pose[:3, 3].copy()
    depth = render_depth(problem.scene, pose, cfg.intrinsics, table=table)
    depth[depth > cfg.max_depth] = np.inf
    depth = add_depth_noise(depth, rng, cfg.depth_noise, cfg.depth_noise_quadratic)
    return crop(depth_to_points(depth, pose, cfg.intrinsics), *planning_crop()), pose[:3, 3].copy()


class ForeignLatentBackend(BackendDefaults):
    """The learned backend for a planner whose VAE is not the one the collision predictor reads.

    The predictor takes the latent of its own VAE: p_collision(q, z) re-encodes the decoded q with that VAE
    (posterior mean, differentiable in q; none for a network that does not read z) instead of passing the
    planner's z.
    """

    name = "learned"

    def __init__(self, backend):
        self.inner = backend

    def set_scene(self, scene, origin: np.ndarray | None = None) -> None:
        self.inner.set_scene(scene, origin)

    @property
    def mode(self) -> str:
        return self.inner.mode

    def set_cloud(self, cloud: np.ndarray, views: int = 1) -> None:
        self.inner.set_cloud(cloud, views)

    def geometric_only(self):
        return self.inner.geometric_only()

    def p_collision(self, q, z, frames=None):
        own = self.inner.predictor.latent_of(q.float())
        return self.inner.p_collision(q, own).to(z.dtype)

    def check(self, q: np.ndarray) -> np.ndarray:
        return self.inner.check(q)


class TableRunner:
    """Builds every planner once (per process) and runs them on one problem at a time.

    Args:
        names: rows of the table (see table_planners.ALL_PLANNERS).
        backend: default collision backend of the AMP-LS rows ("learned" or "geometric").
        table: the scenario set's table flag.
        threads: torch threads.
        checkpoint: collision predictor checkpoint stem of the learned backend ("" = the shipped one).
        overrides: AMP-LS settings applied over every AMP-LS row's own (amp_ls.config.with_overrides).
    """

    def __init__(
        self,
        names: list[str],
        backend: str,
        table: bool,
        threads: int = 1,
        checkpoint: str = "",
        overrides: dict | None = None,
    ):
        import torch

        from latent_planner_ros.models.vae_io import load_vae, shipped_vae_path
        from latent_planner_ros.planning.amp_ls import AmpLs
        from latent_planner_ros.planning.backends import make_backend
        from latent_planner_ros.planning.ompl_baseline import OmplPlanner, seed_ompl
        from latent_planner_ros.robot.collision import CollisionChecker

        torch.set_num_threads(threads)
        seed_ompl(1)  # OMPL takes one seed per process (0 is refused)
        self.table = table
        self.planners: dict = {}
        vaes: dict = {}
        backends: dict = {}
        for name in names:
            if name in AMP_LS_VARIANTS:
                variant, config = AMP_LS_VARIANTS[name], amp_ls_config(name, backend, overrides)
                if variant.vae not in vaes:
                    vaes[variant.vae] = load_vae(shipped_vae_path(variant.vae) if variant.vae else None)[0]
                if config.collision_backend not in backends:
                    backends[config.collision_backend] = make_backend(config.collision_backend, checkpoint)
                backend_used = backends[config.collision_backend]
                if variant.vae and config.collision_backend == "learned":
                    backend_used = ForeignLatentBackend(backend_used)
                planner = AmpLs(vaes[variant.vae], backend_used, config)
                planner.name = name
                planner.checker = CollisionChecker(table=table, convex=True)
                planner.warm_up()
            else:
                planner = OmplPlanner(ompl_config(name, table))
            self.planners[name] = planner

    def run(self, index: int, problem: ScenarioProblem) -> list[dict]:
        """One row per planner for problem `index` (see the module docstring for success)."""
        from latent_planner_ros.evaluation.path_check import PathJudge
        from latent_planner_ros.planning.amp_ls import AmpLs
        from latent_planner_ros.planning.goal import Goal
        from latent_planner_ros.planning.grasp import DEFAULT_APPROACH_M, plan_grasp

        goal = Goal.from_pose(problem.goal_position, problem.goal_quaternion_xyzw, POS_TOL, np.radians(ORI_TOL_DEG))
        cloud, origin = problem_cloud(problem, index, self.table)
        judge = PathJudge(problem.scene, self.table)
        start_ee = judge.panda.fk(problem.start).translation
        distance = float(np.linalg.norm(start_ee - goal.position))
        rows = []
        for name, planner in self.planners.items():
            if isinstance(planner, AmpLs):
                planner.generator.manual_seed(index)  # the extra latent seeds depend on the problem only
            if problem.grasp:  # the same semantics for every planner: planning/grasp.py
                approach = DEFAULT_APPROACH_M if problem.approach_m is None else problem.approach_m
                result = plan_grasp(planner, problem.start, goal, cloud, origin, approach)
            else:
                result = planner.plan(problem.start, goal, cloud, origin)
            verdict = judge.judge(result.q_path, goal)  # the target stays an obstacle of the judge
            rows.append(
                {
                    "problem": index,
                    "planner": name,
                    "family": problem.family or "unnamed",
                    "inside": bool(problem.inside),
                    "grasp": bool(problem.grasp),
                    "target_points": int(result.info.get("target_points", 0)),
                    "approach": str(result.info.get("approach", "")),
                    "success": bool(result.success and verdict.reached and not verdict.collision),
                    "claimed": bool(result.success),
                    "reached": bool(verdict.reached),
                    "collision": verdict.collision,
                    "time_s": float(result.planning_time_s),
                    "reason": result.reason,
                    "pos_err_mm": 1000.0 * verdict.pos_err_m,
                    "ori_err_deg": float(np.degrees(verdict.ori_err_rad)),
                    "ee_path_m": verdict.ee_path_m,
                    "joint_path_rad": verdict.joint_path_rad,
                    "path_len_norm": verdict.ee_path_m / max(distance, 1e-6),
                    "start_goal_distance_m": distance,
                    "states_checked": verdict.states_checked,
                    "cloud_points": len(cloud),
                    "cameras": max(1, len(problem.cameras)),
                    "timings": {k: float(v) for k, v in result.timings.items()},
                    "checked_states": int(result.info.get("checked_states", -1)),
                    "collision_backend": str(result.info.get("collision_backend", "")),
                    "escape": str(result.info.get("escape", "")),
                    "escape_seen_only": bool(result.info.get("escape_seen_only", False)),
                    "escape_seen_depth_m": result.info.get("escape_seen_depth_m"),
                    "escape_seen_note": result.info.get("escape_seen_note", ""),
                }
            )
        return rows


def _make_runner(
    names: list[str], backend: str, table: bool, threads: int, checkpoint: str, overrides: dict | None = None
) -> TableRunner:
    os.environ.setdefault("OMP_NUM_THREADS", str(threads))
    return TableRunner(names, backend, table, threads, checkpoint, overrides)


def _run_problem(runner: TableRunner, index: int, problem: ScenarioProblem, deadline: float) -> list[dict]:
    return runner.run(index, problem) if time.time() < deadline else []


def run_table(
    problems,
    names: list[str],
    backend: str,
    table: bool,
    workers: int = 2,
    threads: int = 1,
    checkpoint: str = "",
    minutes: float = 0.0,
    executor: Executor | None = None,
    overrides: dict | None = None,
) -> list[dict]:
    """Rows of every planner on every problem (sorted by problem, then table order), one task per problem on
    `executor` (default: `workers` local processes; each worker builds the planners once). `overrides`: AMP-LS
    settings over every AMP-LS row's own.

    With `minutes` > 0, problems not started within that wall time [min] are skipped (every planner runs on
    every problem that is started, so the comparison stays on the same problems).
    """
    deadline = time.time() + 60.0 * minutes if minutes > 0 else float("inf")
    job = Job(_run_problem, _make_runner, (names, backend, table, threads, checkpoint, overrides))
    rows: list[dict] = []
    bar = tqdm(total=len(problems), desc="bench table", unit="problem", dynamic_ncols=True)
    ex = executor or Executor(ExecutorConfig(workers=workers))  # local processes hold nothing to close
    for _, problem_rows in ex.map(job, [(i, p, deadline) for i, p in enumerate(problems)]):
        rows += problem_rows
        bar.update()
    bar.close()
    order = {n: k for k, n in enumerate(names)}
    return sorted(rows, key=lambda r: (r["problem"], order[r["planner"]]))


def default_backend(checkpoint: str = "") -> tuple[str, str]:
    """("learned", "") when the collision predictor's weights load, else ("geometric", why)."""
    from latent_planner_ros.models.checkpoint import CheckpointError
    from latent_planner_ros.planning.backends import make_backend

    try:
        make_backend("learned", checkpoint)
        return "learned", ""
    except CheckpointError as err:
        return "geometric", f"learned collision weights unavailable ({err}); AMP-LS rows use the geometric backend"


def main(argv: list[str]) -> int:
    p = bench_parser("table", __doc__)
    p.add_argument("--scenarios", "--set", dest="scenarios", type=Path, default=None, help="scenario set JSON")
    p.add_argument("--scenes", "--problems", dest="scenes", type=int, default=None, help="first N problems")
    p.add_argument("--planners", default=None, help="comma-separated rows (default: all)")
    p.add_argument("--backend", default="auto", help="AMP-LS collision backend: auto, learned or geometric")
    p.add_argument("--collision-checkpoint", default="", help="learned backend weights (stem; default: shipped)")
    p.add_argument("--workers", type=int, default=2, help="processes (default 2: both cores)")
    p.add_argument("--minutes", type=float, default=0.0, help="wall-time budget: skip problems not started by then")
    add_executor_args(p)
    p.add_argument("--threads", type=int, default=1, help="torch threads per process")
    p.add_argument(
        "--amp-ls-set", action="append", default=[], metavar="KEY=VALUE",
        help="AMP-LS setting over every AMP-LS row's own, e.g. escape.after_s=0.25 or finish=null (repeatable)",
    )  # fmt: skip
    args = p.parse_args(argv)
    try:
        overrides = parse_overrides(args.amp_ls_set)
    except ValueError as err:
        print(f"bench table: --amp-ls-set: {err}", file=sys.stderr)
        return 2
    try:
        scenarios = load_scenarios(args.scenarios or DEFAULT_SET).head(args.scenes)
    except ScenarioError as err:
        print(f"bench table: {err}", file=sys.stderr)
        return 2
    notes: list[str] = []
    backend = args.backend
    if backend == "auto":
        backend, note = default_backend(args.collision_checkpoint)
        notes += [note] if note else []
    if backend not in ("learned", "geometric"):
        print(f"bench table: --backend must be auto, learned or geometric, got {backend!r}", file=sys.stderr)
        return 2
    try:
        names = parse_planners(args.planners, backend)
    except ValueError as err:
        print(f"bench table: {err}", file=sys.stderr)
        return 2
    problems = list(scenarios.problems)
    with Executor(executor_config(args)) as ex:
        rows = run_table(
            problems, names, backend, scenarios.table, threads=args.threads, checkpoint=args.collision_checkpoint,
            minutes=args.minutes, executor=ex, overrides=overrides,
        )  # fmt: skip
    done = sorted({r["problem"] for r in rows})
    if len(done) < len(problems):
        notes.append(f"wall-time budget {args.minutes:g} min: {len(done)} of {len(problems)} problems run ({done})")
    results = {
        "planners": summarise(rows, names),
        "scenarios": {
            "name": scenarios.name,
            "file": str(args.scenarios or DEFAULT_SET),
            "problems": len(scenarios.problems),
            "problems_run": len(done),
            "table": scenarios.table,
        },
        "backend": backend,
        "collision_checkpoint": args.collision_checkpoint or ("shipped" if backend == "learned" else ""),
        "tolerance": {"position_m": POS_TOL, "orientation_deg": ORI_TOL_DEG},
        "budgets": budgets(overrides),
        "amp_ls_overrides": overrides,
        "workers": args.workers,
        "executor": ex.name,
        "cluster": args.cluster,
        "notes": notes,
        "rows": rows,
    }
    write_report(args.out, "table", results, markdown(results), figures(results, rows), argv)
    return 0

"""Generate benchmark scenario sets: novel tabletop scenes with a feasible start and a reachable target.

Each problem (seeded by (seed, index), so the first N problems of a set do not depend on N):
  1. a random tabletop scene of the held-out family (non-convex composites the collision predictor never saw);
  2. start and goal configurations sampled uniformly among self- and table-collision-free ones that keep
     `clearance` from the TRUE obstacles (exact coal check against the obstacles inflated by `clearance`),
     so the goal pose is reachable by a collision-free configuration (`goal_q`) and a 2 cm occupancy map
     of a noisy cloud does not swallow the start;
  3. the TCP moves at least `min_distance` between them, and (as in the seed's scenes) the direct motion
     (the straight joint-space line start -> goal_q) collides with an obstacle;
  4. a camera viewpoint drawn from the default camera ranges, stored with its depth-noise seed.

    python -m latent_planner_ros.bench.scenario_generator --out my_set.json --problems 100 --seed 8000

The shipped default set is this command's output with its defaults (DEFAULT_SET).

With a workcell family (`--family bookshelf|bin|cage|undershelf|wall|mixed`, or `workcell` to cycle through
all six) the problems come from bench/workcell_problems.py instead: furniture around the arm, `--goal
pregrasp|inside|mixed` goals at or inside it, `--split train|heldout` scene variants, several cameras; `--goal
grasp` makes grasp problems instead (bench/grasp_problems.py: goals at small objects, the fingers around them).
"""

from __future__ import annotations

import argparse
import sys
from dataclasses import dataclass

import numpy as np
from tqdm import tqdm

from latent_planner_ros.bench.problem_checks import direct_motion_collides, inflated
from latent_planner_ros.bench.scenarios import (
    DEFAULT_SET,
    DIGITS,
    CameraSpec,
    ScenarioProblem,
    ScenarioSet,
    round_obstacle,
    save_scenarios,
)
from latent_planner_ros.data.camera import CameraConfig, sample_camera_pose
from latent_planner_ros.data.labels import CollisionLabeler
from latent_planner_ros.data.obstacles import obstacle_from_dict, obstacle_to_dict
from latent_planner_ros.data.scene import Scene
from latent_planner_ros.data.scene_generator import generate_scene
from latent_planner_ros.robot.panda import load_panda
from latent_planner_ros.robot.rotations import matrix_to_quat
from latent_planner_ros.robot.sampler import FeasibleSampler


@dataclass(frozen=True)
class GeneratorConfig:
    """Settings of a generated set (recorded in the file under "generator")."""

    problems: int = 100
    seed: int = 8000
    """base seed; problem i uses numpy SeedSequence([seed, i])"""
    family: str = "heldout"
    """scene family of data/scene_generator.py ("heldout": shapes never used in training)"""
    clearance: float = 0.03
    """start and goal_q keep this distance [m] from the true obstacles"""
    min_distance: float = 0.25
    """smallest TCP distance [m] between start and goal"""
    blocked: bool = True
    """require that the straight joint-space motion start -> goal_q collides with an obstacle"""
    candidates: int = 48
    """feasible configurations drawn per scene"""
    pairs_per_scene: int = 12
    """start/goal pairs tried per scene before drawing a new scene"""


def generate_problem(index: int, config: GeneratorConfig, max_scenes: int = 200) -> ScenarioProblem:
    """Problem `index` of a set (deterministic in (config.seed, index)); RuntimeError if none is found."""
    rng = np.random.default_rng(np.random.SeedSequence([config.seed, index]))
    sampler = FeasibleSampler(rng)
    panda = load_panda()
    for _ in range(max_scenes):
        scene = generate_scene(rng, config.family)
        # round to the file's precision first, so the checks below hold for what is written
        obstacles = tuple(obstacle_from_dict(round_obstacle(obstacle_to_dict(o), DIGITS)) for o in scene.obstacles)
        grown = CollisionLabeler(Scene(tuple(inflated(o, config.clearance) for o in obstacles)))
        q = sampler.sample(config.candidates)
        q = np.round(q, DIGITS)
        free = q[~grown.label(q).any(axis=1)]
        if len(free) < 2:
            continue
        ee, rot = panda.fk_batch(free)
        true_labeler = CollisionLabeler(Scene(obstacles))
        tried = 0
        for a in range(len(free)):
            for b in range(len(free)):
                if a == b or np.linalg.norm(ee[a] - ee[b]) < config.min_distance:
                    continue
                tried += 1
                if tried > config.pairs_per_scene:
                    break
                if config.blocked and not direct_motion_collides(true_labeler, free[a], free[b]):
                    continue
                camera = sample_camera_pose(rng, CameraConfig())
                target = camera[:3, 3] + camera[:3, 2]  # one metre along the optical axis
                return ScenarioProblem(
                    start=free[a],
                    goal_position=ee[b],
                    goal_quaternion_xyzw=matrix_to_quat(rot[b]),
                    obstacles=obstacles,
                    goal_q=free[b],
                    cameras=(
                        CameraSpec(tuple(camera[:3, 3].tolist()), tuple(target.tolist()), int(rng.integers(2**31))),
                    ),
                )
            if tried > config.pairs_per_scene:
                break
    raise RuntimeError(f"no problem found for index {index} in {max_scenes} scenes")


def generate_set(config: GeneratorConfig, name: str = "tabletop_heldout", progress: bool = True) -> ScenarioSet:
    """A set of config.problems problems (see the module docstring)."""
    problems = tuple(
        generate_problem(i, config)
        for i in tqdm(range(config.problems), desc="scenarios", disable=not progress, dynamic_ncols=True)
    )
    description = (
        f"{config.problems} novel tabletop scenes ({config.family} shape family), collision-free start and goal "
        f"configurations with {config.clearance * 100:g} cm clearance, TCP moves >= {config.min_distance} m"
        + (", the direct joint-space motion collides" if config.blocked else "")
    )
    extra = {k: getattr(config, k) for k in config.__dataclass_fields__}
    return ScenarioSet(name, problems, table=True, description=description, extra=extra)


def _write_family_set(args: argparse.Namespace, config_cls: type, generate, prefix: str, **fields) -> int:
    """Generate and write a set of `config_cls` (defaults from it, CLI values over them) with `generate`; the
    set is named `<prefix>_<split>` unless --name says otherwise."""
    config = config_cls(
        problems=config_cls.problems if args.problems is None else args.problems,
        seed=config_cls.seed if args.seed is None else args.seed,
        family=args.family,
        split=args.split,
        clearance=args.clearance,
        min_distance=args.min_distance,
        blocked=not args.any_motion,
        **fields,
    )
    name = args.name or f"{prefix}_{config.split}"
    out = args.out or DEFAULT_SET.parent / f"{name}_{config.problems}.json"
    path = save_scenarios(generate(config, name), out, DIGITS)
    print(f"wrote {path} ({path.stat().st_size / 1e3:.0f} kB)", file=sys.stderr)
    return 0


def _grasp_main(args: argparse.Namespace) -> int:
    """The CLI for grasp problems in workcell families (bench/grasp_problems.py); defaults from GraspSetConfig."""
    from latent_planner_ros.bench.grasp_problems import GraspSetConfig, generate_grasp_set

    return _write_family_set(args, GraspSetConfig, generate_grasp_set, "grasp")


def _workcell_main(args: argparse.Namespace) -> int:
    """The CLI for workcell families (bench/workcell_problems.py); defaults from WorkcellConfig."""
    from latent_planner_ros.bench.workcell_problems import WorkcellConfig, generate_workcell_set

    return _write_family_set(args, WorkcellConfig, generate_workcell_set, args.family, goal=args.goal)


def main(argv: list[str] | None = None) -> int:
    from latent_planner_ros.data.workcell_generator import WORKCELL_FAMILIES

    p = argparse.ArgumentParser(prog="python -m latent_planner_ros.bench.scenario_generator", description=__doc__)
    p.add_argument("--out", default=None, help="output JSON file (default: the shipped default set)")
    p.add_argument("--problems", type=int, default=None, help="default 100 (tabletop), 120 (workcell)")
    p.add_argument("--seed", type=int, default=None, help="base seed; default 8000 (tabletop), 8500 (workcell)")
    p.add_argument(
        "--family",
        default=GeneratorConfig.family,
        choices=("heldout", "train", *WORKCELL_FAMILIES, "workcell"),
        help="tabletop shape family (heldout, train) or workcell family (workcell: all six in turn)",
    )
    p.add_argument("--goal", default="mixed", choices=("pregrasp", "inside", "mixed", "grasp"), help="workcell goals")
    p.add_argument("--split", default="heldout", choices=("train", "heldout"), help="workcell scene variants")
    p.add_argument("--clearance", type=float, default=GeneratorConfig.clearance, help="[m]")
    p.add_argument("--min-distance", type=float, default=GeneratorConfig.min_distance, help="[m]")
    p.add_argument("--any-motion", action="store_true", help="do not require the direct motion to collide")
    p.add_argument("--name", default=None, help="set name (default: tabletop_heldout, or <family>_<split>)")
    args = p.parse_args(argv)
    if args.family not in ("heldout", "train"):
        return _grasp_main(args) if args.goal == "grasp" else _workcell_main(args)
    config = GeneratorConfig(
        problems=GeneratorConfig.problems if args.problems is None else args.problems,
        seed=GeneratorConfig.seed if args.seed is None else args.seed,
        family=args.family,
        clearance=args.clearance,
        min_distance=args.min_distance,
        blocked=not args.any_motion,
    )
    out = args.out or str(DEFAULT_SET)
    path = save_scenarios(generate_set(config, args.name or "tabletop_heldout"), out, DIGITS)
    print(f"wrote {path} ({path.stat().st_size / 1e3:.0f} kB)", file=sys.stderr)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

"""Grasp problems in workcell scenes: goals AT small objects, the open fingers around them.

Each problem (seeded by (seed, index); `--goal grasp` of scenario_generator.py, families cycled as in
workcell_problems.py):
  1. a workcell scene of the problem's family and an object (data/grasp_objects.py: an upright box or cylinder,
     2-6 cm across its narrow side) standing on a support of the furniture: a shelf board in a slot, a bin's floor,
     the table under a shelf, or the table below a cage window / between pillars (after half the scenes without
     one: the table in front of the furniture; the held-out bins are too deep for the hand with 1.5 cm to spare);
     at least 2 cm from every surface but its support;
  2. the grasp goal: the TCP at the object's centre, the hand's z axis along the region's entry direction
     (within 10 deg of yaw; from above for a bin), the fingers across the narrow side; its configuration (IK)
     keeps `grasp_clearance` from every obstacle but the target and `finger_gap` from the target (the fingers
     surround it without touching), and the straight approach from `approach_m` back (IK every 1 cm) touches no
     true geometry, the target included;
  3. a start as in workcell_problems.pick_start (true obstacles and the target);
  4. the workcell's cameras.
The problem carries `"grasp": true`, `"target"` (the object's index, the last obstacle) and `"approach_m"`.

The shipped set grasp_heldout_60.json is the output of

    python -m latent_planner_ros.bench.scenario_generator --family workcell --goal grasp --split heldout \\
        --problems 60 --seed 8700 --out latent_planner_ros/bench/scenarios/grasp_heldout_60.json
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np
from tqdm import tqdm

from latent_planner_ros.bench.scenarios import DIGITS, ScenarioProblem, ScenarioSet, round_obstacle
from latent_planner_ros.bench.workcell_problems import _ik, default_workcell_cameras, pick_start
from latent_planner_ros.data.grasp_objects import GraspObject, clearance_except_support, draw_object
from latent_planner_ros.data.labels import CollisionLabeler
from latent_planner_ros.data.obstacles import obstacle_from_dict, obstacle_to_dict
from latent_planner_ros.data.scene import Scene
from latent_planner_ros.data.workcell_clearance import ArmDistance
from latent_planner_ros.data.workcell_generator import REACH, SHOULDER, WORKCELL_FAMILIES, generate_workcell_layout
from latent_planner_ros.data.workcell_regions import Region
from latent_planner_ros.planning.goal import Goal
from latent_planner_ros.planning.ik import IkConfig, solve_ik
from latent_planner_ros.robot.panda import PandaModel, load_panda
from latent_planner_ros.robot.rotations import matrix_to_quat
from latent_planner_ros.robot.sampler import FeasibleSampler

_STEP_IK = IkConfig(max_iters=60, stall_iters=15)


@dataclass(frozen=True)
class GraspSetConfig:
    """Settings of a generated grasp set (recorded in the file under "generator")."""

    problems: int = 60
    seed: int = 8700
    family: str = "workcell"
    """a name of WORKCELL_FAMILIES, or "workcell" to cycle through all of them"""
    split: str = "heldout"
    goal: str = "grasp"
    clearance: float = 0.03
    """the start keeps this distance [m] from the true obstacles"""
    grasp_clearance: float = 0.015
    """the grasp configuration keeps this distance [m] from every obstacle but the target"""
    finger_gap: float = 0.003
    """the grasp configuration keeps this distance [m] from the target"""
    object_clearance: float = 0.02
    """the object keeps this distance [m] from every surface but its support"""
    approach_m: float = 0.08
    """[m] pre-grasp distance back along the hand's z axis"""
    min_distance: float = 0.25
    blocked: bool = True
    candidates: int = 48
    goal_tries: int = 12

    def families(self) -> tuple[str, ...]:
        return WORKCELL_FAMILIES if self.family == "workcell" else (self.family,)


def _support(region: Region) -> float | None:
    """Height [m] of the surface an object in `region` stands on: a slot's board or a bin's floor (the region's
    bottom), the table (0) under a shelf or below a low window / gap; None for a region too high above the table."""
    bottom = float(region.centre[2] - np.abs(region.axes[2]) @ np.asarray(region.half_extents))
    if region.kind in ("slot", "bin"):
        return bottom
    return 0.0 if bottom < 0.3 else None


def _table_in_front(furniture) -> Region:
    """A 30 x 30 cm patch of the table 10-40 cm in front of a piece of furniture, entered towards it."""
    front = np.asarray(furniture.front, dtype=float)
    yaw = float(np.arctan2(-front[1], -front[0]))
    axes = np.array([[np.cos(yaw), -np.sin(yaw), 0.0], [np.sin(yaw), np.cos(yaw), 0.0], [0.0, 0.0, 1.0]])
    centre = np.asarray(furniture.anchor, dtype=float) + 0.25 * front + np.array([0.0, 0.0, 0.15])
    return Region(tuple(centre.tolist()), axes, (0.15, 0.15, 0.15), tuple((-front).tolist()), "table")


class _GraspSearch:
    def __init__(self, obstacles, config: GraspSetConfig, panda: PandaModel, checker):
        self.obstacles, self.config, self.panda, self.checker = obstacles, config, panda, checker

    def draw(self, rng: np.random.Generator, region: Region) -> tuple[GraspObject, np.ndarray] | None:
        """An object in region and a grasp configuration (7,) [rad] meeting the module's conditions, or None."""
        cfg = self.config
        support = _support(region)
        if support is None:
            return None
        xy = region.sample(rng, margin=0.05)[:2]
        horizontal = np.asarray(region.half_extents)[:2]
        long_axis = region.axes[:, int(np.argmax(horizontal))]
        obj = draw_object(rng, xy, support, np.asarray(region.approach), long_axis=long_axis)
        target = obstacle_from_dict(round_obstacle(obstacle_to_dict(obj.obstacle), DIGITS))
        obj = GraspObject(target, obj.tcp_rotation)
        if clearance_except_support(target, self.obstacles, support) < cfg.object_clearance:
            return None
        q = _ik(self.panda, obj.centre, obj.tcp_rotation, rng)
        if q is None:
            return None
        q = np.round(q, DIGITS)
        if self.checker.in_collision(q) or ArmDistance(self.obstacles)(q).distance < cfg.grasp_clearance:
            return None
        if ArmDistance([target])(q).distance < cfg.finger_gap or not self._approach_free(q, obj, target):
            return None
        return obj, q

    def _approach_free(self, q: np.ndarray, obj: GraspObject, target) -> bool:
        """The straight approach from approach_m back to the grasp (IK every 1 cm from q) hits no true geometry."""
        labeler = CollisionLabeler(Scene((*self.obstacles, target)))
        z = obj.tcp_rotation[:, 2]
        states = [q]
        for d in np.arange(0.01, self.config.approach_m + 1e-9, 0.01):
            sol = solve_ik(self.panda, Goal(obj.centre - d * z, obj.tcp_rotation), states[-1], _STEP_IK)
            if not sol.converged or np.abs(sol.q - states[-1]).max() > 0.1:
                return False
            states.append(sol.q)
        path = np.array(states)
        t = np.linspace(0, 1, 4)[:, None]
        dense = np.concatenate([a + (b - a) * t for a, b in zip(path[:-1], path[1:], strict=True)])
        return not labeler.label(dense).any() and self.checker.feasible(dense).all()


def generate_grasp_problem(index: int, config: GraspSetConfig, max_scenes: int = 100) -> ScenarioProblem:
    """Problem `index` of a grasp set (deterministic in (config.seed, index)); RuntimeError if none is found."""
    rng = np.random.default_rng(np.random.SeedSequence([config.seed, index]))
    fams = config.families()
    family = fams[index % len(fams)]
    panda, sampler = load_panda(), FeasibleSampler(rng)
    for attempt in range(max_scenes):
        cell = generate_workcell_layout(rng, family, index, config.split)
        obstacles = tuple(obstacle_from_dict(round_obstacle(obstacle_to_dict(o), DIGITS)) for o in cell.scene.obstacles)
        # after half the scenes without a grasp inside the furniture (deep held-out bins leave the hand no 1.5 cm),
        # the table in front of it
        inner = cell.regions if attempt < max_scenes // 2 else tuple(_table_in_front(f) for f in cell.furniture)
        regions = [
            r
            for r in inner
            if _support(r) is not None and np.linalg.norm(np.asarray(r.centre) - SHOULDER) < REACH + 0.05
        ]
        if not regions:
            continue
        search = _GraspSearch(obstacles, config, panda, sampler.checker)
        found = None
        for _ in range(config.goal_tries):
            found = search.draw(rng, regions[int(rng.integers(len(regions)))])
            if found is not None:
                break
        if found is None:
            continue
        obj, goal_q = found
        everything = (*obstacles, obj.obstacle)
        start = pick_start(sampler, panda, everything, goal_q, config)
        if start is None:
            continue
        goal_p, goal_r = panda.fk_batch(goal_q)
        return ScenarioProblem(
            start=start,
            goal_position=goal_p[0],
            goal_quaternion_xyzw=matrix_to_quat(goal_r[0]),
            obstacles=everything,
            goal_q=goal_q,
            cameras=tuple(default_workcell_cameras(cell, rng)),
            family=family,
            grasp=True,
            target=len(obstacles),
            approach_m=config.approach_m,
        )
    raise RuntimeError(f"no {family} grasp problem found for index {index} in {max_scenes} scenes")


def generate_grasp_set(config: GraspSetConfig, name: str = "grasp_heldout", progress: bool = True) -> ScenarioSet:
    """A set of config.problems grasp problems (see the module docstring)."""
    problems = tuple(
        generate_grasp_problem(i, config)
        for i in tqdm(range(config.problems), desc="grasp scenarios", disable=not progress, dynamic_ncols=True)
    )
    description = (
        f"{config.problems} grasp problems in workcell scenes ({'/'.join(config.families())}, {config.split} "
        f"variants): the TCP at a 2-6 cm wide object on a board, a bin floor or the table, fingers around it "
        f"({config.finger_gap * 1000:g} mm from it), the arm {config.grasp_clearance * 100:g} cm from everything "
        f"else, a free straight approach of {config.approach_m * 100:g} cm; start with {config.clearance * 100:g} cm "
        f"clearance, TCP moves >= {config.min_distance} m"
        + (", the direct joint-space motion collides" if config.blocked else "")
    )
    return ScenarioSet(name, problems, table=True, description=description, extra=asdict(config))

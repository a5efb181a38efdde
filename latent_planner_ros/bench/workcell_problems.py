"""Reaching problems in workcell scenes (data/workcell_generator.py): goals at and inside furniture.

Each problem (seeded by (seed, index), like the tabletop set of scenario_generator.py):
  1. a workcell scene of the problem's family (`family` "workcell" cycles: problem i gets WORKCELL_FAMILIES[i % 6]);
  2. a goal of one of two kinds (`goal` "mixed": problem i is an inside goal when (i + i // F) % 3 == 0, F the
     number of families cycled, so a third of every family's problems):
     - pregrasp: the TCP 2-6 cm off a furniture surface (a board's front edge, a bin's rim, the underside of a
       shelf, a bar, a wall), its approach axis (TCP z) within 15 deg of pointing into the surface; goal_q keeps
       `goal_clearance` from every obstacle;
     - inside: the TCP inside a region (a shelf slot, a bin, under a shelf, a cage window, a gap between
       pillars), approaching along the region's entry direction within 15 deg, and the whole arm (every link,
       hand and fingers) 1.5-4 cm from the nearest obstacle surface (coal distance);
     goal configurations come from damped-least-squares IK of sampled target poses; an inside target is moved
     towards (or away from) the nearest obstacle until the clearance falls in the band;
  3. a start configuration free of self and table collisions that keeps `clearance` from the true obstacles,
     the TCP moving at least `min_distance`, and (when `blocked`) the straight joint-space motion start ->
     goal_q colliding with an obstacle;
  4. 2-3 cameras that see into the furniture (data/workcell_cameras.py), each with its depth-noise seed.

The shipped held-out set (workcell_heldout_120.json) is the output of

    python -m latent_planner_ros.bench.scenario_generator --family workcell --goal mixed --split heldout \\
        --problems 120 --seed 8500 --out latent_planner_ros/bench/scenarios/workcell_heldout_120.json

in 30 s (16 s of CPU time, about 0.13 s per problem on one core of the 2-core development machine); the file
is 246 kB (furniture is primitives only).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np
from scipy.spatial.transform import Rotation
from tqdm import tqdm

from latent_planner_ros.bench.problem_checks import direct_motion_collides, inflated
from latent_planner_ros.bench.scenarios import DIGITS, CameraSpec, ScenarioProblem, ScenarioSet, round_obstacle
from latent_planner_ros.data.camera import CameraConfig, sample_camera_pose
from latent_planner_ros.data.labels import CollisionLabeler
from latent_planner_ros.data.obstacles import obstacle_from_dict, obstacle_to_dict
from latent_planner_ros.data.scene import Scene
from latent_planner_ros.data.workcell_cameras import clutter_viewpoint, workcell_viewpoints
from latent_planner_ros.data.workcell_clearance import ArmDistance
from latent_planner_ros.data.workcell_generator import (
    REACH,
    SHOULDER,
    WORKCELL_FAMILIES,
    Workcell,
    generate_workcell_layout,
)
from latent_planner_ros.data.workcell_regions import Furniture, Region, Surface
from latent_planner_ros.planning.goal import Goal
from latent_planner_ros.planning.ik import IkConfig, solve_ik
from latent_planner_ros.robot.collision import CollisionChecker
from latent_planner_ros.robot.limits import Q_MAX, Q_MIN, Q_READY
from latent_planner_ros.robot.panda import PandaModel, load_panda
from latent_planner_ros.robot.rotations import matrix_to_quat
from latent_planner_ros.robot.sampler import FeasibleSampler

GOAL_KINDS = ("pregrasp", "inside", "mixed")
IK = IkConfig(max_iters=80, stall_iters=15)
"""IK of sampled goal poses (a failed seed costs little: another pose is drawn)"""


@dataclass(frozen=True)
class WorkcellConfig:
    """Settings of a generated workcell set (recorded in the file under "generator")."""

    problems: int = 120
    seed: int = 8500
    """base seed; problem i uses numpy SeedSequence([seed, i])"""
    family: str = "workcell"
    """a name of WORKCELL_FAMILIES, or "workcell" to cycle through all of them"""
    goal: str = "mixed"
    """"pregrasp", "inside", or "mixed" (a third inside goals)"""
    split: str = "heldout"
    """"train" or "heldout" scene variants (data/workcell_generator.py)"""
    clearance: float = 0.03
    """the start keeps this distance [m] from the true obstacles"""
    goal_clearance: float = 0.01
    """a pregrasp goal_q keeps this distance [m] from the true obstacles"""
    inside_band: tuple[float, float] = (0.015, 0.04)
    """an inside goal_q's smallest arm-obstacle distance lies in this range [m]"""
    pregrasp_offset: tuple[float, float] = (0.02, 0.06)
    """range of the pregrasp TCP's distance [m] from its surface point, along the surface normal"""
    tilt_deg: float = 15.0
    """largest angle [deg] between the TCP's z axis and the approach direction"""
    min_distance: float = 0.25
    """smallest TCP distance [m] between start and goal"""
    blocked: bool = True
    """require that the straight joint-space motion start -> goal_q collides with an obstacle"""
    candidates: int = 48
    """feasible start configurations drawn per scene"""
    goal_tries: int = 8
    """target poses tried per scene"""

    def families(self) -> tuple[str, ...]:
        return WORKCELL_FAMILIES if self.family == "workcell" else (self.family,)

    def problem_kind(self, index: int) -> tuple[str, bool]:
        """(family, inside goal) of problem `index`."""
        fams = self.families()
        inside = {"inside": True, "pregrasp": False}.get(self.goal, (index + index // len(fams)) % 3 == 0)
        return fams[index % len(fams)], inside


def approach_rotation(rng: np.random.Generator, approach: np.ndarray, tilt_deg: float) -> np.ndarray:
    """A (3, 3) TCP orientation whose z axis is within tilt_deg [deg] of `approach` (3,), random roll."""
    z = np.asarray(approach, dtype=float) / np.linalg.norm(approach)
    axis = np.cross(z, rng.normal(size=3))
    axis /= np.linalg.norm(axis)
    tilt = Rotation.from_rotvec(axis * math.radians(rng.uniform(0.0, tilt_deg)))
    roll = Rotation.from_rotvec(z * rng.uniform(-math.pi, math.pi))
    x0 = np.cross(z, [0.0, 0.0, 1.0]) if abs(z[2]) < 0.9 else np.cross(z, [1.0, 0.0, 0.0])
    base = np.stack([x0 / np.linalg.norm(x0), np.cross(z, x0 / np.linalg.norm(x0)), z], 1)
    return (tilt * roll).as_matrix() @ base


def _ik(panda: PandaModel, p: np.ndarray, rot: np.ndarray, rng: np.random.Generator, warm=None) -> np.ndarray | None:
    """A configuration (7,) [rad] putting the TCP at p (3,) [m] with orientation rot (3, 3), or None."""
    goal = Goal(np.asarray(p, dtype=float), rot)
    facing = Q_READY.copy()
    facing[0] = np.clip(math.atan2(p[1], p[0]), Q_MIN[0], Q_MAX[0])
    seeds = ([warm] if warm is not None else []) + [facing, rng.uniform(Q_MIN, Q_MAX)]
    for seed in seeds:
        sol = solve_ik(panda, goal, seed, IK)
        if sol.converged:
            return sol.q
    return None


class _GoalSearch:
    """Goal configurations for the targets of one scene (its obstacles already rounded)."""

    def __init__(self, obstacles, config: WorkcellConfig, panda: PandaModel, checker: CollisionChecker):
        self.distance = ArmDistance(obstacles)
        self.config, self.panda, self.checker = config, panda, checker

    def tcp(self, q: np.ndarray) -> np.ndarray:
        return self.panda.fk(q).translation

    def valid(self, q: np.ndarray, region: Region | None) -> bool:
        """Whether q (7,) [rad] is a goal: free of self/table collision, and its clearance [m] fits the kind."""
        if self.checker.in_collision(q):
            return False
        d = self.distance(q).distance
        if region is None:
            return d >= self.config.goal_clearance
        lo, hi = self.config.inside_band
        return lo <= d <= hi and region.contains(self.tcp(q))

    def pregrasp(self, rng: np.random.Generator, surface: Surface) -> np.ndarray | None:
        n = np.asarray(surface.normal)
        p = surface.sample(rng) + n * rng.uniform(*self.config.pregrasp_offset)
        q = _ik(self.panda, p, approach_rotation(rng, -n, self.config.tilt_deg), rng)
        return q if q is not None and self.valid(q, None) else None

    def inside(self, rng: np.random.Generator, region: Region, nudges: int = 3) -> np.ndarray | None:
        lo, hi = self.config.inside_band
        p = region.sample(rng, margin=0.02)
        rot = approach_rotation(rng, np.asarray(region.approach), self.config.tilt_deg)
        q = _ik(self.panda, p, rot, rng)
        for _ in range(nudges + 1):
            if q is None or self.checker.in_collision(q):
                return None
            c = self.distance(q)
            if lo <= c.distance <= hi and region.contains(self.tcp(q)):
                return q
            if c.distance <= 0.0:
                return None
            # move the TCP (and with it the hand) so the clearance lands in the middle of the band
            u = (c.on_obstacle - c.on_arm) / max(float(np.linalg.norm(c.on_obstacle - c.on_arm)), 1e-9)
            p = p + u * (c.distance - (lo + hi) / 2)
            if not region.contains(p):
                return None
            q = _ik(self.panda, p, rot, rng, warm=q)
        return None


def pick_start(sampler: FeasibleSampler, panda: PandaModel, obstacles, goal_q: np.ndarray, config) -> np.ndarray | None:
    """A start (7,) [rad] among config.candidates feasible samples that keeps config.clearance [m] from the true
    obstacles, has its TCP config.min_distance [m] from goal_q's (7,) and (config.blocked) whose straight motion
    to goal_q collides; None if no sample qualifies."""
    goal_p = panda.fk_batch(goal_q)[0]
    q = np.round(sampler.sample(config.candidates), DIGITS)
    grown = CollisionLabeler(Scene(tuple(inflated(o, config.clearance) for o in obstacles)))
    free = q[~grown.label(q).any(axis=1)]
    far = free[np.linalg.norm(panda.fk_batch(free)[0] - goal_p, axis=1) >= config.min_distance] if len(free) else free
    true_labeler = CollisionLabeler(Scene(obstacles))
    return next((s for s in far if not config.blocked or direct_motion_collides(true_labeler, s, goal_q)), None)


def _reachable(targets):
    return [t for t in targets if np.linalg.norm(np.asarray(t.centre) - SHOULDER) < REACH + 0.1]


def default_workcell_cameras(
    scene_or_furniture: Workcell | Furniture | Scene, rng: np.random.Generator
) -> list[CameraSpec]:
    """2-3 fixed viewpoints with depth-noise seeds that see into the (first) piece of furniture.

    A plain Scene (no furniture known) gets two viewpoints from the default camera ranges."""
    if isinstance(scene_or_furniture, Scene):
        views = []
        for _ in range(2):
            pose = sample_camera_pose(rng, CameraConfig())
            views.append((pose[:3, 3], pose[:3, 3] + pose[:3, 2]))
    elif isinstance(scene_or_furniture, Workcell):
        cell = scene_or_furniture
        views = workcell_viewpoints(cell.furniture[0], rng, cell.scene.obstacles)
        clutter = [o for o, g in zip(cell.scene.obstacles, cell.scene.groups, strict=True) if g > 0]
        if clutter:  # objects beside the furniture (the mixed family): one of the views is theirs
            views = views[:2] + [clutter_viewpoint(clutter, rng, cell.scene.obstacles)]
    else:
        views = workcell_viewpoints(scene_or_furniture, rng)
    return [CameraSpec(tuple(e.tolist()), tuple(t.tolist()), int(rng.integers(2**31))) for e, t in views]


def generate_workcell_problem(index: int, config: WorkcellConfig, max_scenes: int = 100) -> ScenarioProblem:
    """Problem `index` of a set (deterministic in (config.seed, index)); RuntimeError if none is found."""
    return workcell_problem_and_target(index, config, max_scenes)[0]


def workcell_problem_and_target(
    index: int, config: WorkcellConfig, max_scenes: int = 100
) -> tuple[ScenarioProblem, Region | Surface]:
    """Problem `index` and the region (inside goal) or surface (pregrasp goal) its goal was drawn for."""
    rng = np.random.default_rng(np.random.SeedSequence([config.seed, index]))
    family, inside = config.problem_kind(index)
    panda, sampler = load_panda(), FeasibleSampler(rng)
    for _ in range(max_scenes):
        cell = generate_workcell_layout(rng, family, index, config.split)
        obstacles = tuple(obstacle_from_dict(round_obstacle(obstacle_to_dict(o), DIGITS)) for o in cell.scene.obstacles)
        targets = _reachable(cell.regions if inside else cell.surfaces)
        if not targets:
            continue
        search = _GoalSearch(obstacles, config, panda, sampler.checker)
        goal_q = None
        for _ in range(config.goal_tries):
            target = targets[int(rng.integers(len(targets)))]
            q = search.inside(rng, target) if inside else search.pregrasp(rng, target)
            if q is not None:
                q = np.round(q, DIGITS)
                goal_q = q if search.valid(q, target if inside else None) else None
            if goal_q is not None:
                break
        if goal_q is None:
            continue
        goal_p, goal_r = panda.fk_batch(goal_q)
        start = pick_start(sampler, panda, obstacles, goal_q, config)
        if start is None:
            continue
        problem = ScenarioProblem(
            start=start,
            goal_position=goal_p[0],
            goal_quaternion_xyzw=matrix_to_quat(goal_r[0]),
            obstacles=obstacles,
            goal_q=goal_q,
            cameras=tuple(default_workcell_cameras(cell, rng)),
            family=family,
            inside=inside,
        )
        return problem, target
    raise RuntimeError(f"no {family} problem found for index {index} in {max_scenes} scenes")


def generate_workcell_set(config: WorkcellConfig, name: str = "workcell_heldout", progress: bool = True) -> ScenarioSet:
    """A set of config.problems problems (see the module docstring)."""
    if config.goal not in GOAL_KINDS:
        raise ValueError(f"unknown goal kind {config.goal!r}; choose one of {GOAL_KINDS}")
    problems = tuple(
        generate_workcell_problem(i, config)
        for i in tqdm(range(config.problems), desc="workcell scenarios", disable=not progress, dynamic_ncols=True)
    )
    lo, hi = config.inside_band
    description = (
        f"{config.problems} workcell scenes ({'/'.join(config.families())}, {config.split} variants), {config.goal} "
        f"goals (pregrasp: TCP {config.pregrasp_offset[0] * 100:g}-{config.pregrasp_offset[1] * 100:g} cm off a "
        f"surface; inside: TCP in a slot/bin/region with the arm {lo * 100:g}-{hi * 100:g} cm from the nearest "
        f"surface), start with {config.clearance * 100:g} cm clearance, TCP moves >= {config.min_distance} m"
        + (", the direct joint-space motion collides" if config.blocked else "")
    )
    return ScenarioSet(name, problems, table=True, description=description, extra=asdict(config))

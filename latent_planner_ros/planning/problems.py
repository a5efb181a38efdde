"""Reaching problems for tests and benchmarks: free space and cluttered tabletop scenes.

A problem is a collision-free feasible start configuration, a goal pose of `panda_hand_tcp` that a
collision-free feasible configuration reaches, and (cluttered) the scene with the point cloud a virtual
camera sees of it. Everything is seeded, so a benchmark run can be repeated exactly.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from latent_planner_ros.data.camera import CameraConfig, planning_crop
from latent_planner_ros.data.labels import CollisionLabeler
from latent_planner_ros.data.render import scene_view
from latent_planner_ros.data.scene import Scene
from latent_planner_ros.data.scene_generator import generate_scene
from latent_planner_ros.planning.goal import Goal
from latent_planner_ros.robot.panda import load_panda
from latent_planner_ros.robot.sampler import FeasibleSampler


@dataclass
class Problem:
    """One reaching problem.

    Attributes:
        start_q: (7,) start configuration [rad].
        goal: target pose with tolerances.
        goal_q: (7,) a collision-free configuration reaching the goal (not given to planners).
        cloud: (N, 3) [m] observed points in `world` (empty in free space).
        origin: (3,) [m] the camera's optical centre the cloud was seen from (None in free space).
        scene: the obstacles (None in free space), for exact collision checks of the result.
    """

    start_q: np.ndarray
    goal: Goal
    goal_q: np.ndarray
    cloud: np.ndarray = field(default_factory=lambda: np.zeros((0, 3), dtype=np.float32))
    scene: Scene | None = None
    origin: np.ndarray | None = None


def _goal_of(q: np.ndarray, pos_tol: float, ori_tol: float) -> Goal:
    tf = load_panda().fk(q)
    return Goal(np.asarray(tf.translation, dtype=float), np.asarray(tf.rotation, dtype=float), pos_tol, ori_tol)


def free_space_problems(n: int, seed: int = 0, pos_tol: float = 0.01, ori_tol: float = np.radians(15.0)):
    """n problems (list[Problem]) between random self- and table-collision-free configurations."""
    rng = np.random.default_rng(seed)
    q = FeasibleSampler(rng).sample(2 * n)
    return [Problem(q[2 * i], _goal_of(q[2 * i + 1], pos_tol, ori_tol), q[2 * i + 1]) for i in range(n)]


def cluttered_problems(
    n: int,
    seed: int = 0,
    family: str = "heldout",
    pos_tol: float = 0.01,
    ori_tol: float = np.radians(15.0),
    camera: CameraConfig | None = None,
) -> list[Problem]:
    """n problems in random tabletop scenes of `family` ("train" or "heldout"), one camera view each.

    Start and goal configurations are independent uniform samples free of self, table and obstacle
    collision (exact coal labels).
    """
    rng = np.random.default_rng(seed)
    low, high = planning_crop()  # the planners' clouds reach as high as the arm
    camera = replace(camera or CameraConfig(), crop_min=low, crop_max=high)
    sampler = FeasibleSampler(rng)
    out: list[Problem] = []
    while len(out) < n:
        scene = generate_scene(rng, family)
        labeler = CollisionLabeler(scene)
        q = sampler.sample(32)
        free = q[~labeler.label(q).any(axis=1)]
        if len(free) < 2:
            continue
        start, goal_q = free[0], free[1]
        cloud, origin = scene_view(scene, rng, camera)
        out.append(Problem(start, _goal_of(goal_q, pos_tol, ori_tol), goal_q, cloud, scene, origin))
    return out


def path_collides(problem: Problem, q_path: np.ndarray, step_rad: float = 0.02) -> bool:
    """Exact check of a joint path (K, 7) against the problem's obstacles, densified to `step_rad` [rad]."""
    if problem.scene is None or not problem.scene.obstacles:
        return False
    q_path = np.atleast_2d(q_path)
    dense = [q_path[:1]]
    for a, b in zip(q_path[:-1], q_path[1:], strict=True):
        k = max(1, int(np.ceil(np.abs(b - a).max() / step_rad)))
        dense.append(a + (b - a) * (np.arange(1, k + 1) / k)[:, None])
    return bool(CollisionLabeler(problem.scene).label(np.concatenate(dense)).any())

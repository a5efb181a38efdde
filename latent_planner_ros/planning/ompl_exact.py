"""The OMPL baseline with the obstacles known exactly (LSPP mode: upright cylinders, seed chapter 6 V-B).

Everything is `OmplPlanner` (IK goal states, OMPL search, simplification, time parameterisation) except the
validity checker: `SceneChecker` tests the arm's collision meshes against the obstacles' exact coal geometry
instead of an occupancy map of a point cloud. Position-only goals (ori_tol >= pi) get goal states of any
orientation from the IK (`planning.ik`).

    planner = ExactOmplPlanner(OmplConfig(planner="rrtconnect"))
    planner.set_cylinders(o)                 # (K, 4) rows (x, y, h, r) [m]; or set_scene(scene)
    result = planner.plan(start_q, goal)     # a PlanResult; a cloud, if passed, is ignored
"""

from __future__ import annotations

import time

import numpy as np

from latent_planner_ros.data.cylinders import cylinder_scene
from latent_planner_ros.data.scene import Scene
from latent_planner_ros.planning.goal import Goal
from latent_planner_ros.planning.ompl_baseline import OmplPlanner
from latent_planner_ros.planning.ompl_baseline_config import OmplConfig
from latent_planner_ros.planning.scene_checker import SceneChecker
from latent_planner_ros.robot.panda import PandaModel


class ExactOmplPlanner(OmplPlanner):
    """An OMPL planner that checks configurations against a known scene's exact geometry.

    Not thread-safe: use one instance per thread or process. `config.octree_resolution` and `config.min_z`
    are unused; `config.padding` and `config.table` apply to the exact checks.

    Args:
        config: planner choice, budgets, IK and output settings.
        panda: the pinocchio model (default: the shared one).
        scene: the obstacles (default: none until `set_scene` or `set_cylinders`).
    """

    checker: SceneChecker

    def __init__(self, config: OmplConfig | None = None, panda: PandaModel | None = None, scene: Scene | None = None):
        super().__init__(config, panda)
        self.checker = SceneChecker(scene, table=self.config.table, padding=self.config.padding, panda=self.panda)

    def set_scene(self, scene: Scene) -> None:
        """Plan around the obstacles of `scene` from the next `plan` on."""
        self.checker.set_scene(scene)

    def set_cylinders(self, cylinders: np.ndarray) -> None:
        """Plan around upright cylinders (K, 4), rows (x, y, h, r) [m] (see `data.cylinders`)."""
        self.set_scene(cylinder_scene(cylinders))

    def _load_obstacles(self, cloud: np.ndarray | None, timings: dict, info: dict) -> None:
        t = time.perf_counter()
        info["obstacles"] = len(self.checker.scene.obstacles)
        info["cloud_ignored"] = cloud is not None
        timings["scene_s"] = time.perf_counter() - t

    def _goal_blocked(self, goal: Goal) -> str | None:
        if self.checker.contains(goal.position):
            return "the goal position is inside an obstacle"
        return None

"""Judging a planned joint path against the TRUE scene: reached the goal, and collision-free when executed.

The path is densified so that the TCP moves at most `ee_step` and no joint more than `joint_step` between two
checked states; every checked state is tested against the true obstacles (exact coal meshes), and for self and
table collision (pinocchio + coal). Reaching is judged by pinocchio FK of the last state.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from latent_planner_ros.data.labels import CollisionLabeler
from latent_planner_ros.data.scene import Scene
from latent_planner_ros.planning.goal import Goal
from latent_planner_ros.robot.collision import CollisionChecker
from latent_planner_ros.robot.panda import PandaModel, load_panda


@dataclass(frozen=True)
class PathVerdict:
    """What the dense check found.

    Attributes:
        reached: the last state's TCP is within the goal's tolerances.
        collision: "" if free, else what was hit first ("obstacle", "table or self").
        pos_err_m, ori_err_rad: error of the last state's TCP to the goal.
        states_checked: number of densified states checked.
        ee_path_m: TCP path length [m] (over the densified path).
        joint_path_rad: joint-space path length [rad] (Euclidean, summed over segments).
    """

    reached: bool
    collision: str
    pos_err_m: float
    ori_err_rad: float
    states_checked: int
    ee_path_m: float
    joint_path_rad: float


def densify_by_ee(
    q_path: np.ndarray, panda: PandaModel, ee_step: float = 0.01, joint_step: float = 0.02
) -> tuple[np.ndarray, np.ndarray]:
    """States (T', 7) on the polyline q_path (T, 7) [rad] and their TCP positions (T', 3) [m].

    Each segment is split until consecutive TCP positions are at most ee_step [m] apart and no joint moves more
    than joint_step [rad].
    """
    q_path = np.atleast_2d(np.asarray(q_path, dtype=float))
    states, positions = [q_path[:1]], [panda.fk_batch(q_path[:1])[0]]
    for a, b in zip(q_path[:-1], q_path[1:], strict=True):
        k = max(1, math.ceil(float(np.abs(b - a).max()) / joint_step))
        while True:
            seg = a + (b - a) * (np.arange(1, k + 1) / k)[:, None]
            pos = panda.fk_batch(seg)[0]
            gaps = np.linalg.norm(np.diff(np.vstack([positions[-1][-1:], pos]), axis=0), axis=1)
            if gaps.max() <= ee_step or k >= 4096:
                break
            k = int(math.ceil(k * gaps.max() / ee_step)) + 1
        states.append(seg)
        positions.append(pos)
    return np.concatenate(states), np.concatenate(positions)


class PathJudge:
    """Checks paths in one scene (builds the coal objects once).

    Args:
        scene: the true obstacles.
        table: the table half-space z < 0 counts as an obstacle.
        ee_step, joint_step: densification bounds [m], [rad].
    """

    def __init__(self, scene: Scene, table: bool = True, ee_step: float = 0.01, joint_step: float = 0.02):
        self.panda = load_panda()
        self.labeler = CollisionLabeler(scene)
        self.checker = CollisionChecker(panda=self.panda, table=table)
        self.ee_step, self.joint_step = ee_step, joint_step

    def judge(self, q_path: np.ndarray, goal: Goal) -> PathVerdict:
        q_path = np.atleast_2d(np.asarray(q_path, dtype=float))
        dense, ee = densify_by_ee(q_path, self.panda, self.ee_step, self.joint_step)
        tf = self.panda.fk(q_path[-1])
        pos_err = float(np.linalg.norm(tf.translation - goal.position))
        ori_err = float(np.linalg.norm(pin.log3(tf.rotation.T @ goal.rotation)))
        reached = bool(pos_err < goal.pos_tol and ori_err < goal.ori_tol)
        collision = ""
        if self.labeler.label(dense).any():
            collision = "obstacle"
        elif not self.checker.feasible(dense).all():
            collision = "table or self"
        return PathVerdict(
            reached=reached,
            collision=collision,
            pos_err_m=pos_err,
            ori_err_rad=ori_err,
            states_checked=len(dense),
            ee_path_m=float(np.linalg.norm(np.diff(ee, axis=0), axis=1).sum()),
            joint_path_rad=float(np.linalg.norm(np.diff(q_path, axis=0), axis=1).sum()),
        )

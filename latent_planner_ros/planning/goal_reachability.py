"""A fast answer for goals the arm cannot take at all, before any latent optimisation.

A goal is refused only when multi-seed damped-least-squares IK (planning/ik.py, the OMPL baseline's) finds no
configuration for its pose, or finds some and every one of them collides with the robot itself or the table.
Obstacles seen in the cloud do not refuse a goal here (a narrow shelf slot may still be reachable by a pose the
seeds missed): the planner decides those. A refusal costs about 0.1-0.3 s; a reachable goal usually the first
seed (a few ms).
"""

from __future__ import annotations

import numpy as np

from latent_planner_ros.planning.goal import Goal
from latent_planner_ros.planning.ik import IkConfig, goal_configurations, is_position_only
from latent_planner_ros.planning.result import PlanResult, result_from_path
from latent_planner_ros.robot.collision import CollisionChecker
from latent_planner_ros.robot.panda import PandaModel

REACHABILITY_IK = IkConfig(n_seeds=12, max_solutions=1, timeout_s=0.3, stall_iters=20)
"""IK for the check: one valid solution suffices; a bounded search"""


def unreachable_reason(
    panda: PandaModel,
    checker: CollisionChecker,
    goal: Goal,
    start_q: np.ndarray,
    config: IkConfig = REACHABILITY_IK,
    seed: int = 0,
) -> str:
    """ "" if goal can be taken by some configuration free of self and table collision, else why not (e.g. "no
    valid IK solution: all 5 IK solutions are invalid (5 table collision)"). start_q (7,) [rad] seeds the IK first;
    the goal's own tolerances (halved) bound the IK's; a seed that ends within the goal's tolerances without
    converging to the IK's does not refuse the goal."""

    def invalid(q: np.ndarray) -> str | None:
        self_hit, table_hit = checker.collisions(q) if checker.in_collision(q) else (False, False)
        return "self-collision" if self_hit else "table collision" if table_hit else None

    search = goal_configurations(panda, goal, start_q, invalid, config, np.random.default_rng(seed))
    near = search.best_pos_err <= goal.pos_tol and (is_position_only(goal) or search.best_ori_err <= goal.ori_tol)
    if search.solutions or (search.converged == 0 and near):
        return ""
    return search.failure_reason()


def refused_result(panda: PandaModel, start_q: np.ndarray, goal: Goal, reason: str, t0: float) -> PlanResult:
    """The failed PlanResult of a goal refused before planning: the start alone, `reason` as given."""
    q = np.asarray(start_q, dtype=float)[None]
    return result_from_path(panda, q, goal, solved=False, reason=reason, t0=t0, speed_scale=1.0)

"""Evasion of observed obstacles that approach a holding arm (planning/evasion.py, ClosedLoopController)."""

import numpy as np

from latent_planner_ros.planning.amp_ls import AmpLsConfig, StepResult
from latent_planner_ros.planning.closed_loop import WARN, ClosedLoopConfig, ClosedLoopController
from latent_planner_ros.planning.evasion import HORIZON_M, Evader
from latent_planner_ros.planning.goal import Goal
from latent_planner_ros.robot.collision import CollisionChecker
from latent_planner_ros.robot.limits import Q_READY, V_MAX
from latent_planner_ros.robot.panda import load_panda

TCP = load_panda().fk(Q_READY).translation


def _wall(y_offset: float) -> np.ndarray:
    """A 20 x 20 cm wall of points (N, 3) [m] facing the TCP, y_offset [m] from it along +y."""
    u, w = np.meshgrid(np.linspace(-0.1, 0.1, 21), np.linspace(-0.1, 0.1, 21))
    return np.stack([TCP[0] + u.ravel(), np.full(u.size, TCP[1] + y_offset), TCP[2] + w.ravel()], axis=1)


def _evader_with(clouds: list[tuple[float, np.ndarray]]) -> Evader:
    ev = Evader(0.05)
    for t, cloud in clouds:
        ev.add_cloud(cloud, t)
    return ev


def test_approach_speed_is_the_clearance_lost_at_a_fixed_configuration():
    ev = _evader_with([(0.0, _wall(0.22)), (0.1, _wall(0.21)), (0.2, _wall(0.2)), (0.3, _wall(0.19))])
    clearance, speed = ev.threat(Q_READY)
    assert 0.0 < clearance < 0.06  # the hand's spheres reach 13.5 cm past the TCP along y
    assert abs(speed - 0.03 / 0.3) < 0.01  # 3 cm in 0.3 s
    assert ev.least_clearance(Q_READY, newest=False) - clearance > 0.025
    still = _evader_with([(0.0, _wall(0.19)), (0.3, _wall(0.19))])
    assert abs(still.threat(Q_READY)[1]) < 1e-9
    assert _evader_with([]).threat(Q_READY) == (HORIZON_M, 0.0)


def test_retreat_moves_away_within_the_step_limit_and_stays_free_of_self_and_table_collision():
    ev = _evader_with([(0.0, _wall(0.16))])
    before = ev.least_clearance(Q_READY)
    assert before < 0.05
    max_step = 0.5 * V_MAX * 0.1
    q = ev.retreat(Q_READY, max_step)
    assert q is not None
    assert np.all(np.abs(q - Q_READY) <= max_step + 1e-9)
    assert ev.least_clearance(q) > before
    assert CollisionChecker().feasible(q[None])[0]
    assert load_panda().fk(q).translation[1] < TCP[1]  # away from the wall at +y
    far = _evader_with([(0.0, _wall(0.4))])
    assert far.retreat(Q_READY, max_step) is None  # nothing within the margin: no reason to move


class _BlockedPlanner:
    """A planner whose every step is back-traced: it commands a hold (AmpLs.step's interface)."""

    config = AmpLsConfig(collision_backend="geometric")
    resets = 0

    def reset(self) -> None:
        self.resets += 1

    def step(self, q, goal, scene, dt, max_iterations, budget_s=None, accepted_steps=1):
        return StepResult(np.asarray(q), False, False, 0.5, 0.0, 0.0, "backtraced: interpolated step collides", {})


def _run(c: ClosedLoopController, walls: list[float], goal: bool = True):
    out = None
    for k, y in enumerate(walls):
        now = 0.1 * k
        c.set_joint_state(Q_READY, now)
        c.set_scene(_wall(y), now, cloud=_wall(y))
        if c.goal is None and goal:
            assert c.set_goal(Goal(TCP + np.array([0.0, 0.4, 0.0]), np.eye(3)), now)[0]
        out = c.tick(now)
    return out


def test_a_holding_arm_retreats_from_an_approaching_obstacle_and_holds_near_a_still_one():
    planner = _BlockedPlanner()
    out = _run(ClosedLoopController(planner, ClosedLoopConfig()), [0.21, 0.2, 0.19, 0.18, 0.17])
    assert out.state == "evading" and out.level == WARN and "approaches at" in out.reason
    assert not np.allclose(out.command, Q_READY) and planner.resets >= 1  # re-encoded where the arm went
    assert out.values["approach_mps"] > 0.05 and out.values["clearance_m"] < 0.05
    still = _run(ClosedLoopController(_BlockedPlanner(), ClosedLoopConfig()), [0.17] * 5)
    assert still.state == "tracking" and np.array_equal(still.command, Q_READY)
    off = _run(ClosedLoopController(_BlockedPlanner(), ClosedLoopConfig(evade_margin_m=0.0)), [0.21, 0.19, 0.17])
    assert off.state == "tracking" and np.array_equal(off.command, Q_READY)


def test_an_arm_holding_without_a_goal_evades_too_but_not_on_a_stale_cloud():
    c = ClosedLoopController(_BlockedPlanner(), ClosedLoopConfig())
    approaching = [0.21, 0.2, 0.19, 0.18, 0.17]
    out = _run(c, approaching, goal=False)
    assert out.state == "evading" and not np.allclose(out.command, Q_READY)
    stale = ClosedLoopController(_BlockedPlanner(), ClosedLoopConfig(stale_scene_s=0.5))
    _run(stale, approaching, goal=False)
    stale.set_joint_state(Q_READY, 1.1)  # the last cloud is 0.7 s old
    out = stale.tick(1.1)
    assert out.state == "idle" and "no goal" in out.reason and out.command is None


class _StepPlanner(_BlockedPlanner):
    """A planner whose every step is accepted and moves the arm by dq (7,) [rad]."""

    def __init__(self, dq: np.ndarray):
        self.dq = dq

    def step(self, q, goal, scene, dt, max_iterations, budget_s=None, accepted_steps=1):
        return StepResult(np.asarray(q) + self.dq, True, False, 0.5, 0.0, 0.0, "tracking", {})


def test_an_accepted_step_is_replaced_by_a_retreat_only_when_it_does_not_gain_clearance():
    approaching = [0.21, 0.2, 0.19, 0.18, 0.17]
    towards = np.array([0.05, 0, 0, 0, 0, 0, 0])  # joint 1 turns the hand towards the wall at +y
    wall = _evader_with([(0.0, _wall(0.17))])
    assert wall.least_clearance(Q_READY + towards) < wall.least_clearance(Q_READY)
    out = _run(ClosedLoopController(_StepPlanner(towards), ClosedLoopConfig()), approaching)
    assert out.state == "evading" and load_panda().fk(out.command).translation[1] < TCP[1]
    out = _run(ClosedLoopController(_StepPlanner(-towards), ClosedLoopConfig()), approaching)
    assert out.state == "tracking" and np.allclose(out.command, Q_READY - towards)


def test_a_step_that_edges_away_slower_than_the_obstacle_comes_is_replaced_by_a_retreat():
    """The wall comes 1 cm per 0.1 s tick: a step that gains 0.8 cm is overrun (a conveyor's obstacle at 14 cm/s
    touched an arm whose local steps each edged away a little); one that gains 1.6 cm is kept."""
    approaching = [0.21, 0.2, 0.19, 0.18, 0.17]
    away = -np.array([0.05, 0, 0, 0, 0, 0, 0])  # turns the hand away from the wall at +y
    wall = _evader_with([(0.0, _wall(0.17))])
    gain = wall.least_clearance(Q_READY + 0.5 * away) - wall.least_clearance(Q_READY)
    assert 0.0 < gain < 0.01
    out = _run(ClosedLoopController(_StepPlanner(0.5 * away), ClosedLoopConfig()), approaching)
    assert out.state == "evading" and wall.least_clearance(out.command) > wall.least_clearance(Q_READY + 0.5 * away)
    out = _run(ClosedLoopController(_StepPlanner(away), ClosedLoopConfig()), approaching)
    assert out.state == "tracking" and np.allclose(out.command, Q_READY + away)

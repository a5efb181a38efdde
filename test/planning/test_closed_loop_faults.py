"""Closed-loop supervision under faulty inputs: implausible measured states, holds inside the limits, and
holds that do not count against the no-progress watchdog."""

import numpy as np

from latent_planner_ros.planning.amp_ls import AmpLs, AmpLsConfig, StepResult
from latent_planner_ros.planning.closed_loop import MEASURED_LIMIT_TOL_RAD, ClosedLoopConfig, ClosedLoopController
from latent_planner_ros.planning.geometric_backend import GeometricBackend
from latent_planner_ros.planning.goal import Goal
from latent_planner_ros.robot.limits import Q_MAX, Q_MIN, Q_READY, V_MAX
from latent_planner_ros.robot.panda import load_panda


def _controller(vae, **cfg):
    planner = AmpLs(vae, GeometricBackend(), AmpLsConfig(collision_backend="geometric"))
    return ClosedLoopController(planner, ClosedLoopConfig(**cfg))


def _goal(dq):
    m = load_panda().fk(Q_READY + np.asarray(dq))
    return Goal(m.translation, m.rotation)


def test_a_measured_state_far_outside_the_limits_is_refused_and_ages(shipped_vae):
    c = _controller(shipped_vae)
    assert c.set_joint_state(Q_READY, 0.0) == (True, "")
    beyond = Q_READY.copy()
    beyond[0] = Q_MAX[0] + 0.6
    ok, reason = c.set_joint_state(beyond, 0.1)
    assert not ok and "outside the joint limits: panda_joint1 = 3.497 rad" in reason
    np.testing.assert_array_equal(c.fresh_joint_state(0.2), Q_READY)  # the last plausible state, until stale
    assert c.fresh_joint_state(0.6) is None
    assert c.tick(0.6).command is None


def test_holds_are_commanded_inside_the_limits(shipped_vae):
    c = _controller(shipped_vae)
    q = Q_READY.copy()
    q[5] = Q_MIN[5] - 0.5 * MEASURED_LIMIT_TOL_RAD  # slightly outside: plausible, accepted
    assert c.set_joint_state(q, 0.0)[0]
    assert c.tick(0.1).command is None  # no goal: no command
    assert c.set_goal(_goal([0.3, 0, 0, 0, 0, 0, 0]), 0.1)[0]
    out = c.tick(0.2)  # no scene yet: hold
    assert out.state == "holding" and out.command[5] == Q_MIN[5]
    assert np.all(np.abs(out.command - q) <= V_MAX * 0.1)


class _StuckPlanner:
    """A planner whose error never improves: only the watchdog decides (AmpLs.step's interface)."""

    config = AmpLsConfig(collision_backend="geometric")

    def reset(self) -> None:
        pass

    def step(self, q, goal, scene, dt, max_iterations, budget_s=None, accepted_steps=1):
        return StepResult(np.asarray(q), True, False, 0.1, 0.0, 0.0, "tracking", {})


def test_time_spent_holding_does_not_trip_the_watchdog():
    """No progress is judged only over time spent optimising: a hold (the camera was off) does not count."""
    c = ClosedLoopController(_StuckPlanner(), ClosedLoopConfig(no_progress_s=1.0, stale_scene_s=0.3))
    c.set_goal(_goal([0.6, 0.25, 0.0, 0.3, 0.0, 0.0, 0.0]), 0.0)
    now = 0.0
    for _ in range(3):  # 0.3 s of optimising without progress: within the watchdog's 1 s
        now += 0.1
        c.set_joint_state(Q_READY, now)
        c.set_scene(np.zeros((0, 3)), now)
        assert c.tick(now).state == "tracking"
    for _ in range(20):  # 2 s more without a fresh scene: the arm holds
        now += 0.1
        c.set_joint_state(Q_READY, now)
        out = c.tick(now)
    assert out.state == "holding" and "scene" in out.reason
    for _ in range(5):  # the scene is back: 0.5 s of optimising since the hold ended
        now += 0.1
        c.set_joint_state(Q_READY, now)
        c.set_scene(np.zeros((0, 3)), now)
        assert c.tick(now).state == "tracking"
    for _ in range(7):  # still no progress: now the watchdog gives up
        now += 0.1
        c.set_joint_state(Q_READY, now)
        c.set_scene(np.zeros((0, 3)), now)
        out = c.tick(now)
    assert out.state == "failed" and "no progress" in out.reason

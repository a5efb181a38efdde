"""AMP-LS core: limits, time parameterisation, back-tracing, closed-loop steps."""

import numpy as np
import pytest

from latent_planner_ros.planning.amp_ls import AmpLs, AmpLsConfig
from latent_planner_ros.planning.amp_ls.config import with_overrides
from latent_planner_ros.planning.collision_backend import NoCollision
from latent_planner_ros.planning.geometric_backend import GeometricBackend
from latent_planner_ros.planning.goal import Goal
from latent_planner_ros.planning.time_parameterisation import interpolate, time_parameterise
from latent_planner_ros.robot.limits import Q_MAX, Q_MIN, Q_READY, V_MAX
from latent_planner_ros.robot.panda import load_panda


def _goal_of(q: np.ndarray) -> Goal:
    m = load_panda().fk(q)
    return Goal(m.translation, m.rotation)


def _check_path(result, speed_scale=0.5):
    q, t = result.q_path, result.times
    assert np.all(q >= Q_MIN - 1e-9) and np.all(q <= Q_MAX + 1e-9)
    v = np.abs(np.diff(q, axis=0)) / np.maximum(np.diff(t), 1e-12)[:, None]
    assert np.all(v <= speed_scale * V_MAX * (1 + 1e-6))
    np.testing.assert_allclose(result.ee_positions[0], load_panda().fk(q[0]).translation, atol=1e-9)


def test_free_space_plan_reaches_a_nearby_goal(shipped_vae):
    goal_q = Q_READY + np.array([0.4, 0.2, -0.2, 0.3, 0.1, -0.2, 0.3])
    planner = AmpLs(shipped_vae, NoCollision(), with_overrides(AmpLsConfig(use_collision=False), {"search.n_seeds": 4}))
    result = planner.plan(Q_READY, _goal_of(goal_q))
    assert result.success, result.reason
    assert result.final_pos_err_m < 0.01 and result.final_ori_err_rad < np.radians(15)
    _check_path(result)
    np.testing.assert_array_equal(result.q_path[0], Q_READY)


class CostBlindBackend(GeometricBackend):
    """A collision cost that sees nothing (as a wrong learned predictor would) over the exact check."""

    def p_collision(self, q, z, frames=None):
        return super().p_collision(q, z) * 0.0


@pytest.mark.parametrize(("keep", "lazy"), [(0.0, False), (0.5, False), (0.0, True)])
def test_a_wall_of_points_triggers_back_tracing_and_is_never_crossed(shipped_vae, keep, lazy):
    """Back-tracing (to the last accepted state, or keeping half of a colliding step's free part, or, checking
    lazily, to the state before the first colliding step) never lets a state of the returned path (shortcut
    included) touch the wall, and the path stays connected."""
    start = Q_READY.copy()
    goal_q = Q_READY + np.array([1.2, 0.3, 0.0, 0.3, 0.0, -0.2, 0.0])
    goal = _goal_of(goal_q)
    # a dense wall of points across the straight line from the start TCP to the goal
    a, b = load_panda().fk(start).translation, goal.position
    mid = (a + b) / 2
    normal = (b - a) / np.linalg.norm(b - a)
    u = np.cross(normal, [0, 0, 1.0])
    u /= np.linalg.norm(u)
    s, h = np.meshgrid(np.linspace(-0.12, 0.12, 25), np.linspace(-0.15, 0.15, 31))
    wall = mid + s.reshape(-1, 1) * u + h.reshape(-1, 1) * np.array([0, 0, 1.0])
    backend = CostBlindBackend()
    cfg = with_overrides(
        AmpLsConfig(collision_backend="geometric", max_steps=200), {"checks.backtrace_keep": keep, "checks.lazy": lazy}
    )
    result = AmpLs(shipped_vae, backend, cfg).plan(start, goal, wall)
    assert result.info["backtraces"] > 0
    backend.set_scene(wall)
    assert not backend.check(result.q_path).any()  # no state of the returned path touches the wall
    assert np.all(np.abs(np.diff(result.q_path, axis=0)) <= cfg.checks.check_step_rad + 1e-9)
    _check_path(result)


def test_closed_loop_step_respects_velocity_limits_and_limits(shipped_vae):
    planner = AmpLs(shipped_vae, NoCollision(), AmpLsConfig(use_collision=False))
    goal = _goal_of(Q_READY + np.array([0.8, 0.3, 0.0, 0.4, 0.0, 0.0, 0.0]))
    q = Q_READY.copy()
    reached = False
    for _ in range(150):
        out = planner.step(q, goal, dt=0.1, max_iterations=3)
        assert np.all(np.abs(out.command - q) <= 0.5 * V_MAX * 0.1 + 1e-9)
        assert np.all(out.command >= Q_MIN) and np.all(out.command <= Q_MAX)
        q = out.command  # perfect tracking
        reached = reached or out.reached
    assert reached


def test_bad_inputs_are_refused(shipped_vae):
    planner = AmpLs(shipped_vae, NoCollision(), AmpLsConfig(use_collision=False))
    with pytest.raises(ValueError):
        planner.plan(np.full(7, np.nan), _goal_of(Q_READY))
    with pytest.raises(ValueError):
        Goal(np.array([np.nan, 0, 0]), np.eye(3))
    with pytest.raises(ValueError):
        AmpLsConfig(lr=-1.0)
    with pytest.raises(ValueError):
        AmpLsConfig(collision_backend="magic")
    with pytest.raises(ValueError, match="finish.ik_iters"):
        with_overrides(AmpLsConfig(), {"finish.ik_iters": 0})
    with pytest.raises(ValueError, match="finish.ik_step_rad"):
        with_overrides(AmpLsConfig(), {"finish.ik_step_rad": 0.0})


def test_time_parameterisation():
    q = np.stack([Q_READY, Q_READY + 0.1, Q_READY + 0.1])
    t = time_parameterise(q, speed_scale=0.5)
    assert t[0] == 0 and t[1] == pytest.approx(0.1 / (0.5 * V_MAX.min())) and t[2] > t[1]


class AlwaysColliding(NoCollision):
    """Every decoded state is predicted in collision, so no step is ever accepted."""

    def p_collision(self, q, z, frames=None):
        return 0.0 * z.sum(-1) + 0.99


def test_a_tick_stops_starting_steps_when_its_time_budget_is_spent(shipped_vae):
    planner = AmpLs(shipped_vae, AlwaysColliding(), with_overrides(AmpLsConfig(), {"search.closed_loop_seeds": 1}))
    goal = _goal_of(Q_READY + 0.3)
    out = planner.step(Q_READY, goal, max_iterations=5)
    assert not out.accepted and planner.closed_loop_search.iteration == 5  # no budget: every allowed step runs
    planner.reset()
    out = planner.step(Q_READY, goal, max_iterations=5, budget_s=1e-6)
    assert not out.accepted and planner.closed_loop_search.iteration == 1  # at least one step, then the budget stops it
    np.testing.assert_array_equal(out.command, Q_READY)  # nothing accepted: hold


def test_restarts_keep_the_path_continuous(shipped_vae):
    """Stalled seeds restart from the best seed's last accepted state: the returned path must still be one
    connected joint path from the start, with no jump where a seed took over another seed's path."""
    far = Goal(np.array([1.4, 0.0, 0.5]), np.eye(3))  # out of reach: every seed stalls
    cfg = with_overrides(
        AmpLsConfig(use_collision=False, max_steps=150),
        {"search.n_seeds": 4, "search.patience": 5, "search.restarts": 6, "escape": None},
    )  # the latent search alone
    result = AmpLs(shipped_vae, NoCollision(), cfg, seed=3).plan(Q_READY, far)
    assert not result.success and result.info["restarts"] == 6
    np.testing.assert_array_equal(result.q_path[0], Q_READY)
    jumps = np.abs(np.diff(result.q_path, axis=0)).max(axis=1)
    assert jumps.max() <= cfg.checks.check_step_rad + 1e-9
    _check_path(result)


def test_backtrace_keep_must_be_a_fraction():
    with pytest.raises(ValueError, match="checks.backtrace_keep"):
        with_overrides(AmpLsConfig(), {"checks.backtrace_keep": 1.0})


def test_a_tick_can_take_several_accepted_steps(shipped_vae):
    """accepted_steps=2: the tick goes on after its first accepted step, and the latent state gets closer to a
    goal per tick than with one step (free space, perfect tracking)."""
    goal = _goal_of(Q_READY + np.array([0.8, 0.3, 0.0, 0.4, 0.0, 0.0, 0.0]))
    errors = {}
    for steps in (1, 2):
        planner = AmpLs(shipped_vae, NoCollision(), AmpLsConfig(use_collision=False), seed=0)
        q = Q_READY.copy()
        for _ in range(5):
            out = planner.step(q, goal, dt=0.1, max_iterations=3, accepted_steps=steps)
            assert out.accepted
            q = out.command
        errors[steps] = out.pos_err_m
        assert planner.closed_loop_search.iteration >= 5 * steps
    assert errors[2] < errors[1]


class JointSpaceBlock(NoCollision):
    """A hard check that flags states with joints 0 and 1 both 0.1-0.2 rad above Q_READY (a block in joint
    space that a straight segment crosses but a path going first along joint 0, then along joint 1, misses)."""

    def check(self, q):
        d = np.atleast_2d(q) - Q_READY
        return (d[:, 0] > 0.1) & (d[:, 0] < 0.2) & (d[:, 1] > 0.1) & (d[:, 1] < 0.2)


def test_several_accepted_steps_command_the_last_only_when_the_straight_segment_to_it_is_free(shipped_vae):
    planner = AmpLs(shipped_vae, JointSpaceBlock(), with_overrides(AmpLsConfig(), {"checks.self_check": False}))
    first = Q_READY + np.array([0.3, 0.0, 0, 0, 0, 0, 0])
    last = Q_READY + np.array([0.3, 0.3, 0, 0, 0, 0, 0])
    assert not planner.backend.check(interpolate(Q_READY, first, 30)).any()
    assert not planner.backend.check(interpolate(first, last, 30)).any()
    np.testing.assert_array_equal(planner.command_target(Q_READY, last, first), first)  # the diagonal hits
    beside = Q_READY + np.array([0.3, -0.3, 0, 0, 0, 0, 0])
    np.testing.assert_array_equal(planner.command_target(Q_READY, beside, first), beside)


class CountingBackend(GeometricBackend):
    """The exact check, counting the states it is asked about."""

    checked = 0

    def check(self, q):
        self.checked += len(q)
        return super().check(q)


def test_plan_timings_add_up_to_the_total_and_count_the_hard_checked_states(shipped_vae):
    """PlanResult.timings splits the plan's wall time into exclusive sections (scene, check, steps, other, maybe
    ik) that add up to total_s; info["checked_states"] is the number of states the hard check was asked about."""
    goal = _goal_of(Q_READY + np.array([1.2, 0.3, 0.0, 0.3, 0.0, -0.2, 0.0]))
    wall = np.random.default_rng(0).uniform([0.3, -0.3, 0.2], [0.6, 0.3, 0.6], (500, 3))
    backend = CountingBackend()
    result = AmpLs(shipped_vae, backend, AmpLsConfig(collision_backend="geometric")).plan(Q_READY, goal, wall)
    t = result.timings
    assert {"scene_s", "check_s", "other_s", "setup_s", "total_s"} <= set(t)
    assert all(v >= 0 for v in t.values())
    parts = sum(v for k, v in t.items() if k not in ("setup_s", "total_s"))
    assert parts == pytest.approx(t["total_s"], rel=1e-6)
    assert result.info["checked_states"] == backend.checked > 0


def test_an_open_loop_plan_gives_up_at_its_timeout(shipped_vae):
    far = Q_READY + np.array([1.5, 0.4, -0.6, 0.8, 0.5, -0.6, 0.9])
    config = with_overrides(
        AmpLsConfig(use_collision=False), {"search.n_seeds": 2, "plan.timeout_s": 1e-6, "escape": None}
    )
    config.finish.direct_first = False  # no straight segment: the latent search must run
    result = AmpLs(shipped_vae, NoCollision(), config).plan(Q_READY, _goal_of(far))
    assert not result.success and result.reason == "timeout (1e-06 s)"
    assert len(result.q_path) >= 1 and np.array_equal(result.q_path[0], Q_READY)
    with pytest.raises(ValueError, match="plan.timeout_s"):
        with_overrides(AmpLsConfig(), {"plan.timeout_s": -1.0})

"""The RRT escape of AMP-LS: RRTConnect on the planner's hard check when the latent search stalls."""

import gc
import weakref

import numpy as np
import pinocchio as pin
import pytest

from latent_planner_ros.planning.amp_ls import AmpLs, AmpLsConfig
from latent_planner_ros.planning.amp_ls.config import with_overrides
from latent_planner_ros.planning.collision_backend import NoCollision
from latent_planner_ros.planning.escape import GOAL_SLACK, RrtEscape, goal_states
from latent_planner_ros.planning.geometric_backend import GeometricBackend, GeometricBackendConfig
from latent_planner_ros.planning.goal import Goal
from latent_planner_ros.planning.ompl_baseline import seed_ompl
from latent_planner_ros.planning.time_parameterisation import interpolate
from latent_planner_ros.robot.limits import Q_READY
from latent_planner_ros.robot.panda import load_panda

GOAL_Q = Q_READY + np.array([1.2, 0.3, 0.0, 0.3, 0.0, -0.2, 0.0])


@pytest.fixture(autouse=True, scope="module")
def _seeded_ompl():
    seed_ompl(1)  # OMPL takes one seed per process; the tests pass with any


def _goal_of(q: np.ndarray) -> Goal:
    m = load_panda().fk(q)
    return Goal(m.translation, m.rotation)


def _densify(a, b):
    return interpolate(a, b, max(1, int(np.ceil(np.abs(b - a).max() / 0.02))))


def _wall(goal: Goal) -> np.ndarray:
    """A wall of points (1 cm apart, 0.3 m wide, 0.4 m high) across the straight line from the ready pose's TCP to
    the goal, (N, 3) [m]."""
    a, b = load_panda().fk(Q_READY).translation, goal.position
    normal = (b - a) / np.linalg.norm(b - a)
    u = np.cross(normal, [0, 0, 1.0])
    u /= np.linalg.norm(u)
    s, h = np.meshgrid(np.arange(-0.15, 0.15, 0.01), np.arange(-0.2, 0.2, 0.01))
    return (a + b) / 2 + s.reshape(-1, 1) * u + h.reshape(-1, 1) * np.array([0, 0, 1.0])


class ShellBackend(NoCollision):
    """A check that refuses every configuration between 0.15 and 0.3 rad (max joint difference) from the ready pose:
    a shell in C-space that no path from inside to outside crosses; no collision cost."""

    name = "shell"

    def check(self, q):
        d = np.abs(np.atleast_2d(q) - Q_READY).max(axis=1)
        return (d > 0.15) & (d < 0.3)


def _box_free(seg):
    """Free unless joints 0 and 1 are both within 0.3 rad of the ready pose's (a square obstacle in that plane)."""
    return not np.any(np.all(np.abs(np.atleast_2d(seg)[:, :2] - Q_READY[:2]) < 0.3, axis=1))


def test_rrt_connect_goes_around_an_obstacle_on_the_given_check():
    escape = RrtEscape(_box_free, _densify)
    start, goal = Q_READY.copy(), Q_READY.copy()
    start[0], goal[0] = -0.6, 0.6
    out = escape.solve([start], [goal], budget_s=2.0)
    assert out.reason == "found" and out.motions > 0
    v = out.vertices
    np.testing.assert_array_equal(v[0], start)
    np.testing.assert_array_equal(v[-1], goal)
    assert all(_box_free(_densify(a, b)) for a, b in zip(v[:-1], v[1:], strict=True))
    assert not _box_free(_densify(start, goal))  # the straight line is blocked


def test_a_dropped_escape_is_freed_after_it_planned():
    """OMPL holds the escape's callbacks; they must not keep it (and the planner whose check it uses) alive: every
    rebuilt planner would otherwise stay in memory (the planner node's RSS grew about 1 GB per hour of parameter
    changes)."""
    escape = RrtEscape(_box_free, _densify)
    start, goal = Q_READY.copy(), Q_READY.copy()
    start[0], goal[0] = -0.6, 0.6
    assert escape.solve([start], [goal], budget_s=2.0).reason == "found"
    ref = weakref.ref(escape)
    del escape
    gc.collect()
    assert ref() is None
    again = RrtEscape(_box_free, _densify)  # and the next one plans as before
    assert again.solve([start], [goal], budget_s=2.0).reason == "found"


def test_rrt_connect_without_goals_or_time_returns_at_once():
    escape = RrtEscape(_box_free, _densify)
    assert escape.solve([Q_READY], [], 1.0).vertices is None
    assert escape.solve([Q_READY], [Q_READY + 0.5], 0.0).reason == "no time left"


def test_goal_states_repair_exact_solutions_the_check_refuses():
    """A check that refuses every configuration whose TCP is within 4 mm of the goal position: exact IK solutions
    are all refused, the repaired ones sit between 4 mm and the slack of the tolerance from the goal."""
    panda = load_panda()
    goal = _goal_of(GOAL_Q)

    def free(q):
        return bool(np.linalg.norm(panda.fk(np.atleast_2d(q)[0]).translation - goal.position) > 0.004)

    found = goal_states(panda, goal, [Q_READY], free, np.random.default_rng(0), max_states=2, timeout_s=2.0)
    assert found
    for q in found:
        m = panda.fk(q)
        err = np.linalg.norm(m.translation - goal.position)
        assert 0.004 < err <= GOAL_SLACK * goal.pos_tol + 1e-3
        angle = np.linalg.norm(pin.log3(m.rotation.T @ goal.rotation))
        assert angle <= GOAL_SLACK * goal.ori_tol + np.radians(0.5)


def test_the_escape_reaches_a_goal_behind_a_wall_where_the_latent_search_stalls(shipped_vae):
    goal = _goal_of(GOAL_Q)
    wall = _wall(goal)
    base = {"collision_backend": "geometric", "escape.after_s": 60.0}  # the escape starts once all seeds stall
    field = GeometricBackendConfig(distance="field")  # the distance-field cost stalls here (the nearest-point one not)
    stalled = AmpLs(
        shipped_vae,
        GeometricBackend(field),
        with_overrides(AmpLsConfig(collision_backend="geometric"), {"escape": None}),
    ).plan(Q_READY, goal, wall)
    assert not stalled.success and stalled.reason == "no progress" and stalled.info["escape"] == ""
    planner = AmpLs(shipped_vae, GeometricBackend(field), with_overrides(AmpLsConfig(), base))
    result = planner.plan(Q_READY, goal, wall)
    assert result.success, result.reason
    assert result.reason == "reached (escape: rrt)" and result.info["escape"] == "escape: rrt"
    assert result.timings["escape_s"] > 0
    q = result.q_path
    np.testing.assert_array_equal(q[0], Q_READY)
    assert result.final_pos_err_m < goal.pos_tol and result.final_ori_err_rad < goal.ori_tol
    # every state passes the same hard check as every AMP-LS path: spheres vs the cloud, self and table (a start
    # the check refuses lets states within escape_rad of it through, as for any AMP-LS plan)
    check = GeometricBackend()
    check.set_scene(wall)
    away = np.abs(q - Q_READY).max(axis=1) > (
        planner.config.checks.escape_rad if result.info["start_refused"] else -1.0
    )
    assert away.sum() > len(q) // 2 and not check.check(q[away]).any()
    assert planner.checker.feasible(q).all()
    assert np.all(np.abs(np.diff(q, axis=0)) <= planner.config.checks.check_step_rad + 1e-9)


def test_easy_problems_do_not_use_the_escape(shipped_vae, monkeypatch):
    def refuse(*args, **kwargs):
        raise AssertionError("the escape ran on an easy problem")

    monkeypatch.setattr(RrtEscape, "solve", refuse)
    goal = _goal_of(Q_READY + np.array([0.4, 0.2, -0.2, 0.3, 0.1, -0.2, 0.3]))
    far_cloud = np.random.default_rng(0).uniform([-0.6, -0.6, 0.0], [-0.4, -0.4, 0.3], (300, 3))  # behind the arm
    planner = AmpLs(shipped_vae, GeometricBackend(), AmpLsConfig(collision_backend="geometric"))
    assert planner.escape is not None  # on by default
    result = planner.plan(Q_READY, goal, far_cloud)
    assert result.success and result.reason == "reached" and result.info["escape"] == ""
    assert "escape_s" not in result.timings


@pytest.mark.parametrize("attempts", [1, 3])
def test_the_escape_honours_its_time_budget_and_attempts(shipped_vae, attempts):
    """No path exists (a shell around the start in C-space): the escape runs after escape.after_s, keeps to
    escape.budget_s, runs again after_s after a failure until escape.attempts ran, and the plan says why it
    failed."""
    after, budget = 0.1, 0.5
    cfg = with_overrides(
        AmpLsConfig(collision_backend="geometric"),
        {"search.patience": 600, "escape.after_s": after, "escape.budget_s": budget, "escape.attempts": attempts},
    )
    result = AmpLs(shipped_vae, ShellBackend(), cfg).plan(Q_READY, _goal_of(GOAL_Q))
    assert not result.success
    assert "escape: rrt, no path within" in result.reason
    assert result.info["escape_attempts"] == attempts
    spent = result.timings["escape_s"] + result.timings["check_s"]
    assert spent > attempts * 0.5 * budget  # each search ran
    assert result.timings["escape_s"] < attempts * (budget + 0.05)  # and kept to its budget


def test_the_escape_is_off_as_none_and_refuses_bad_values(shipped_vae):
    assert AmpLs(shipped_vae, NoCollision(), with_overrides(AmpLsConfig(), {"escape": None})).escape is None
    for name in ("escape.budget_s", "escape.after_s"):
        with pytest.raises(ValueError, match=name):
            with_overrides(AmpLsConfig(), {name: -1.0})
        with pytest.raises(ValueError, match=name):
            with_overrides(AmpLsConfig(), {name: float("nan")})
    with pytest.raises(ValueError, match="escape.budget_s"):  # a zero budget is not "off": None is
        with_overrides(AmpLsConfig(), {"escape.budget_s": 0.0})

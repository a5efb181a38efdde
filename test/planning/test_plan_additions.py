"""AMP-LS open-loop additions: shortcutting, the exact finish, lazy checks, the escape from a refused start."""

import numpy as np
import pytest

from latent_planner_ros.planning.amp_ls import AmpLs, AmpLsConfig
from latent_planner_ros.planning.amp_ls import finish as finish_part
from latent_planner_ros.planning.amp_ls.config import with_overrides
from latent_planner_ros.planning.collision_backend import NoCollision
from latent_planner_ros.planning.goal import Goal
from latent_planner_ros.planning.ik import solve_ik as original_ik
from latent_planner_ros.planning.shortcut import candidates, shortcut
from latent_planner_ros.planning.time_parameterisation import interpolate
from latent_planner_ros.robot.limits import Q_READY
from latent_planner_ros.robot.panda import load_panda


def _densify(a, b):
    return interpolate(a, b, max(1, int(np.ceil(np.abs(b - a).max() / 0.01))))


def _box_check(segments):
    """Hit where joint 0 and joint 1 are both inside (0.3, 0.7): a square obstacle in the (q0, q1) plane."""
    return [np.all((seg[:, :2] > 0.3) & (seg[:, :2] < 0.7), axis=1) for seg in segments]


def test_candidates_are_furthest_first_and_skip_the_next_vertex():
    assert candidates(0, 10) == [10, 5, 2]
    assert candidates(7, 10) == [10]
    assert candidates(9, 10) == []


def test_a_straight_free_chain_collapses_to_its_ends():
    vertices = np.zeros((12, 7))
    vertices[:, 0] = np.linspace(0.0, 1.1, 12)
    assert shortcut(vertices, _densify, lambda segs: [np.zeros(len(s), bool) for s in segs]) == [0, 11]


def test_shortcuts_go_around_an_obstacle_and_never_through_it():
    # a chain around the square: up joint 1 first, then along joint 0
    up = np.stack([np.zeros(8), np.linspace(0.0, 1.0, 8)], axis=1)
    along = np.stack([np.linspace(0.0, 1.0, 8)[1:], np.ones(7)], axis=1)
    vertices = np.zeros((15, 7))
    vertices[:, :2] = np.concatenate([up, along])
    assert not any(
        h.any() for h in _box_check([_densify(a, b) for a, b in zip(vertices[:-1], vertices[1:], strict=True)])
    )
    kept = shortcut(vertices, _densify, _box_check)
    assert kept[0] == 0 and kept[-1] == 14 and len(kept) < 15 and kept == sorted(kept)
    path = [_densify(vertices[a], vertices[b]) for a, b in zip(kept[:-1], kept[1:], strict=True)]
    assert not any(h.any() for h in _box_check(path))  # the direct segment (0,0) -> (1,1) is never taken
    assert len(kept) > 2


def test_rounds_are_bounded_and_keep_the_rest_of_the_chain():
    vertices = np.zeros((20, 7))
    vertices[:, 0] = np.linspace(0.0, 1.0, 20)
    always_hit = lambda segs: [np.ones(len(s), bool) for s in segs]  # noqa: E731
    assert shortcut(vertices, _densify, always_hit, max_rounds=3) == list(range(20))


def _goal_of(q):
    m = load_panda().fk(q)
    return Goal(m.translation, m.rotation)


def test_the_exact_finish_reaches_sooner_and_ends_on_the_goal(shipped_vae):
    goal = _goal_of(Q_READY + np.array([0.5, 0.2, -0.2, 0.3, 0.1, -0.2, 0.3]))
    base = {"use_collision": False, "search.n_seeds": 4, "plan.shortcut": False}
    plain = AmpLs(shipped_vae, NoCollision(), with_overrides(AmpLsConfig(), {**base, "finish": None}), seed=1).plan(
        Q_READY, goal
    )
    finished = AmpLs(
        shipped_vae, NoCollision(), with_overrides(AmpLsConfig(), {**base, "finish.radius_m": 0.1}), seed=1
    ).plan(Q_READY, goal)
    assert plain.success and finished.success
    assert finished.iterations < plain.iterations
    assert finished.final_pos_err_m < 0.5 * goal.pos_tol  # IK converges well inside the tolerance
    assert np.abs(np.diff(finished.q_path, axis=0)).max() <= AmpLsConfig().checks.check_step_rad + 1e-9


class RefuseFar(NoCollision):
    """The hard check refuses every state whose joint 6 has moved more than 0.3 rad from the start."""

    def check(self, q):
        return np.abs(np.atleast_2d(q)[:, 6] - Q_READY[6]) > 0.3


def test_a_colliding_finish_is_refused_and_lazy_checks_back_trace(shipped_vae, monkeypatch):
    """The goal needs joint 6 turned by 1.2 rad, the check refuses more than 0.3: neither the exact finish nor
    the lazily checked chains may return a refused state; the chains that reached in the model back-trace."""
    goal = _goal_of(Q_READY + np.array([0.3, 0.1, -0.1, 0.2, 0.0, 0.1, 1.2]))
    cfg = with_overrides(
        AmpLsConfig(use_collision=True, max_steps=80),
        {"search.n_seeds": 2, "search.restarts": 0, "finish.radius_m": 0.3, "escape": None},
    )
    solved = []
    monkeypatch.setattr(finish_part, "solve_ik", lambda *a: solved.append(original_ik(*a)) or solved[-1])
    result = AmpLs(shipped_vae, RefuseFar(), cfg, seed=0).plan(Q_READY, goal)
    assert not result.success
    assert sum(sol.converged for sol in solved) > 0  # exact finishes were found, and refused by the check
    assert result.info["backtraces"] > 0
    assert np.all(np.abs(result.q_path[:, 6] - Q_READY[6]) <= 0.3)  # nothing refused is returned
    assert len(result.q_path) > 1 and np.abs(np.diff(result.q_path, axis=0)).max() <= cfg.checks.check_step_rad + 1e-9


class RefuseAroundStart(NoCollision):
    """The hard check refuses every state within 0.03 rad (max joint) of the ready pose, the start included."""

    def check(self, q):
        return np.abs(np.atleast_2d(q) - Q_READY).max(axis=1) < 0.03


def test_a_start_refused_by_the_hard_check_can_be_left_within_escape_rad(shipped_vae):
    goal = _goal_of(Q_READY + np.array([0.4, 0.2, -0.2, 0.3, 0.1, -0.2, 0.3]))
    base = {"use_collision": True, "search.n_seeds": 4, "max_steps": 150}
    stuck = AmpLs(
        shipped_vae, RefuseAroundStart(), with_overrides(AmpLsConfig(), {**base, "checks.escape_rad": 0.0}), seed=1
    ).plan(Q_READY, goal)
    assert not stuck.success and stuck.info["start_refused"] and len(stuck.q_path) == 1
    planner = AmpLs(
        shipped_vae, RefuseAroundStart(), with_overrides(AmpLsConfig(), {**base, "checks.escape_rad": 0.05}), seed=1
    )
    out = planner.plan(Q_READY, goal)
    assert out.success and out.info["start_refused"]
    assert planner.segments.escape_from is None  # the relaxation ends with the plan
    assert not planner.segments.state_free(Q_READY)  # and does not outlive it


# a goal that needs joint 4 near its lower limit: from this start the pose loss stalls (free space, no obstacles)
AWKWARD_START = np.array([-2.211, 1.487, 1.426, -0.075, 1.213, 1.443, -2.315])
AWKWARD_GOAL_Q = np.array([-2.389, 1.653, 1.008, -2.994, 1.847, 1.584, -2.471])


def test_goal_guidance_finishes_a_plan_the_pose_loss_stalls_on(shipped_vae):
    goal = _goal_of(AWKWARD_GOAL_Q)
    base = {"use_collision": False, "max_steps": 400, "escape": None}  # the latent search alone
    plain = AmpLs(shipped_vae, NoCollision(), with_overrides(AmpLsConfig(), {**base, "guidance": None}), seed=0).plan(
        AWKWARD_START, goal
    )
    assert not plain.success and plain.info["goal_configurations"] == -1 and not plain.info["guided"]
    planner = AmpLs(
        shipped_vae, NoCollision(), with_overrides(AmpLsConfig(), {**base, "guidance.solutions": 4}), seed=0
    )
    guided = planner.plan(AWKWARD_START, goal)
    assert guided.success and guided.info["guided"] and guided.info["goal_configurations"] >= 1
    assert guided.final_pos_err_m < goal.pos_tol and guided.final_ori_err_rad < goal.ori_tol
    assert np.abs(np.diff(guided.q_path, axis=0)).max() <= AmpLsConfig().checks.check_step_rad + 1e-9
    assert planner.checker.feasible(guided.q_path).all()  # every state on the path passed the self check


class RefuseNear(NoCollision):
    """The hard check refuses every state within `radius` (0.3 rad, max joint) of q_refused (7,)."""

    def __init__(self, q_refused):
        self.q_refused = q_refused
        self.radius = 0.3

    def check(self, q):
        return np.abs(np.atleast_2d(q) - self.q_refused).max(axis=1) < self.radius


def test_goal_configurations_reach_the_goal_and_pass_the_hard_check(shipped_vae):
    q_goal = Q_READY + np.array([0.5, 0.2, -0.2, 0.3, 0.1, -0.2, 0.3])
    goal = _goal_of(q_goal)
    planner = AmpLs(shipped_vae, RefuseNear(q_goal), with_overrides(AmpLsConfig(), {"guidance.solutions": 3}), seed=0)
    s = planner.new_search(Q_READY)
    found = planner.guidance.configurations(s, goal)
    assert len(found) == 3 and planner.guidance.configurations(s, goal) is found  # searched once per plan
    panda = load_panda()
    for q in found:
        assert np.linalg.norm(panda.fk(q).translation - goal.position) < goal.pos_tol
        assert np.abs(q - q_goal).max() >= 0.3 and planner.segments.state_free(q)
    assert all(np.abs(a - b).max() >= 0.1 for i, a in enumerate(found) for b in found[:i])  # distinct


def test_a_bad_goal_guidance_is_refused_by_name():
    for bad in (-1, 1.5, True):
        with pytest.raises(ValueError, match="guidance.solutions"):
            with_overrides(AmpLsConfig(), {"guidance.solutions": bad})


class Recording(NoCollision):
    """Free everywhere; records every state the hard check sees."""

    def __init__(self):
        self.seen = []

    def check(self, q):
        self.seen.append(np.atleast_2d(q).copy())
        return np.zeros(len(self.seen[-1]), dtype=bool)


def _off_line(q, a, b):
    """Largest distance [rad] of states q (N, 7) from the segment a-b."""
    t = np.clip((q - a) @ (b - a) / ((b - a) @ (b - a)), 0.0, 1.0)
    return np.linalg.norm(q - (a + t[:, None] * (b - a)), axis=1).max()


def test_shortcut_first_checks_the_straight_segment_and_not_the_chain(shipped_vae):
    """Checking lazily with shortcutting on, a seed that reaches the goal first tries the straight segment from the
    start: in free space it is the whole path, and no state of the wandering chain is ever checked."""
    goal = _goal_of(Q_READY + np.array([0.5, 0.2, -0.2, 0.3, 0.1, -0.2, 0.3]))
    backend = Recording()
    cfg = with_overrides(
        AmpLsConfig(use_collision=True), {"search.n_seeds": 4, "checks.lazy": True, "plan.shortcut": True}
    )
    result = AmpLs(shipped_vae, backend, cfg, seed=1).plan(Q_READY, goal)
    assert result.success
    end = result.q_path[-1]
    assert _off_line(result.q_path, Q_READY, end) < 1e-9
    checked = np.concatenate(backend.seen[1:])  # [0]: the start's own check
    assert _off_line(checked, Q_READY, end) < 1e-9
    assert np.abs(np.diff(result.q_path, axis=0)).max() <= cfg.checks.check_step_rad + 1e-9


class RefuseOne(NoCollision):
    """Refuses exactly one configuration."""

    def __init__(self, bad):
        self.bad, self.calls = bad, 0

    def check(self, q):
        self.calls += 1
        return np.all(np.isclose(np.atleast_2d(q), self.bad), axis=1)


@pytest.mark.parametrize("bad_index", [0, 1, 3, 8, 9])
def test_a_segment_is_free_only_if_every_state_passes(shipped_vae, bad_index):
    """SegmentChecker.free checks every 4th state first and the rest after: a refused state anywhere refuses the
    segment, and one refused at a coarse state costs a single check."""
    seg = interpolate(Q_READY, Q_READY + 0.1, 10)
    backend = RefuseOne(seg[bad_index])
    planner = AmpLs(shipped_vae, backend, with_overrides(AmpLsConfig(), {"checks.self_check": False}))
    assert not planner.segments.free(seg)
    assert backend.calls == (1 if bad_index in (3, 7, 9) else 2)
    backend.bad = Q_READY - 1.0
    assert planner.segments.free(seg) and planner.segments.free(seg[:1])


def test_a_refused_straight_segment_is_not_checked_again_for_the_same_end(shipped_vae):
    """Finishes from nearby states find the same IK solution: its straight segment from the start, once refused,
    is skipped (safe: the seed's own steps are checked instead); a different end is checked."""
    backend = RefuseOne(None)
    planner = AmpLs(shipped_vae, backend, with_overrides(AmpLsConfig(), {"checks.self_check": False}))
    s = planner.new_search(Q_READY, n_seeds=1)
    end = Q_READY + np.array([0.4, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0])
    backend.bad = planner.segments.densify(Q_READY, end)[5]
    straight = planner.straight
    assert not straight.try_end(s, 0, end) and backend.calls > 0
    calls = backend.calls
    assert not straight.try_end(s, 0, end + 0.5 * finish_part.DIRECT_SKIP_RAD)
    assert backend.calls == calls  # skipped
    backend.bad = Q_READY - 1.0
    other = end + np.array([0.0, 0.1, 0.0, 0.0, 0.0, 0.0, 0.0])
    assert straight.try_end(s, 0, other) and backend.calls > calls
    assert np.array_equal(s.paths[0][-1][-1], other) and s.pending[0] == []


def test_straight_first_takes_a_free_straight_segment_without_optimising(shipped_vae):
    goal = _goal_of(Q_READY + np.array([0.4, 0.2, -0.2, 0.3, 0.1, -0.2, 0.3]))
    base = {"use_collision": True, "search.n_seeds": 4}
    out = AmpLs(shipped_vae, NoCollision(), with_overrides(AmpLsConfig(), base), seed=0).plan(Q_READY, goal)
    assert out.success and out.info["direct_first"] and out.iterations == 0
    steps = np.diff(out.q_path, axis=0)  # one straight joint-space segment from the start
    np.testing.assert_allclose(steps, np.broadcast_to(steps[0], steps.shape), atol=1e-9)
    assert np.abs(steps).max() <= AmpLsConfig().checks.check_step_rad + 1e-9
    off = AmpLs(
        shipped_vae, NoCollision(), with_overrides(AmpLsConfig(), {**base, "finish.direct_first": False}), seed=0
    ).plan(Q_READY, goal)
    assert off.success and not off.info["direct_first"] and off.iterations > 0


def test_straight_first_refused_by_the_check_goes_on_optimising(shipped_vae, monkeypatch):
    goal = _goal_of(Q_READY + np.array([0.4, 0.2, -0.2, 0.3, 0.1, -0.2, 0.3]))
    q_ik = original_ik(load_panda(), goal, Q_READY, finish_part.IkConfig(max_iters=50, max_step_rad=0.3)).q
    middle = 0.5 * (Q_READY + q_ik)  # the straight segment's middle is refused, start and goal are not
    refuse = RefuseNear(middle)
    refuse.radius = 0.08
    assert np.abs(Q_READY - middle).max() > 0.15 and np.abs(q_ik - middle).max() > 0.15
    cfg = with_overrides(AmpLsConfig(use_collision=True, max_steps=150), {"search.n_seeds": 4})
    out = AmpLs(shipped_vae, refuse, cfg, seed=0).plan(Q_READY, goal)
    assert not out.info["direct_first"] and not out.info["start_refused"] and out.iterations > 0
    assert np.all(np.abs(out.q_path - middle).max(axis=1) >= 0.08)  # nothing refused is returned

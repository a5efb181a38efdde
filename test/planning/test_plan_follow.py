"""Background plans in the closed loop: the runners, following a plan where local steps stall, dropping a blocked
path, a goal changed while its plan runs."""

import threading
import time

import numpy as np
import pytest

from latent_planner_ros.bench.planner import reached
from latent_planner_ros.planning.amp_ls import AmpLs, AmpLsConfig
from latent_planner_ros.planning.closed_loop import ClosedLoopConfig, ClosedLoopController
from latent_planner_ros.planning.geometric_backend import GeometricBackend
from latent_planner_ros.planning.goal import Goal
from latent_planner_ros.planning.plan_runner import (
    DeferredPlanRunner,
    PlanRequest,
    ThreadedPlanRunner,
    planning_function,
)
from latent_planner_ros.planning.problems import cluttered_problems, path_collides
from latent_planner_ros.robot.limits import Q_READY

STALL_SEED, STALL_INDEX = 777, 3
"""A cluttered problem (test seed, not a benchmark's) where one local seed stalls behind an obstacle."""


def _request(ident: int) -> PlanRequest:
    return PlanRequest(Q_READY.copy(), Goal(np.array([0.5, 0.0, 0.4]), np.eye(3)), None, None, ident)


def test_threaded_runner_never_blocks_and_the_newest_request_wins():
    started = threading.Event()

    def slow(request):
        started.set()
        time.sleep(0.3)
        if request.ident == 4:
            raise RuntimeError("planner bug")
        return request.ident

    runner = ThreadedPlanRunner(slow)
    try:
        runner.submit(_request(1))
        assert started.wait(2.0)
        runner.submit(_request(2))
        runner.submit(_request(3))  # replaces 2, which never runs
        t0 = time.perf_counter()
        assert runner.poll() is None and runner.busy
        assert time.perf_counter() - t0 < 0.05
        outcomes = []
        deadline = time.monotonic() + 5.0
        while len(outcomes) < 2 and time.monotonic() < deadline:
            outcome = runner.poll()
            if outcome is not None:
                outcomes.append(outcome)
            time.sleep(0.01)
        assert [o.request.ident for o in outcomes] == [1, 3]
        assert outcomes[1].result == 3 and outcomes[1].wall_s >= 0.3
        runner.submit(_request(4))
        deadline = time.monotonic() + 5.0
        while (outcome := runner.poll()) is None and time.monotonic() < deadline:
            time.sleep(0.01)
        assert outcome.result is None and "planner bug" in outcome.error
        assert not runner.busy
    finally:
        runner.close()


def test_deferred_runner_releases_a_plan_after_its_wall_time():
    def plan(request):
        time.sleep(0.05)
        return request.ident

    runner = DeferredPlanRunner(plan)
    runner.submit(_request(7), now=1.0)
    assert runner.busy and runner.poll(1.0) is None
    assert runner.spent_s >= 0.05
    outcome = runner.poll(1.0 + runner.spent_s + 1e-6)
    assert outcome.result == 7 and not runner.busy


def _planner(vae) -> AmpLs:
    return AmpLs(vae, GeometricBackend(), AmpLsConfig(collision_backend="geometric"))


def _run(vae, problem, follow: bool, ticks: int = 100, on_tick=None):
    """Closed loop against a perfectly tracking arm; (success, states, outcomes, controller)."""
    runner = DeferredPlanRunner(planning_function(_planner(vae))) if follow else None
    c = ClosedLoopController(_planner(vae), ClosedLoopConfig(), runner)
    q, states, outcomes, cloud = problem.start_q.copy(), [problem.start_q.copy()], [], problem.cloud
    c.set_joint_state(q, 0.0)
    c.set_scene(cloud, 0.0, cloud=cloud)
    c.set_goal(problem.goal, 0.0)
    for k in range(ticks):
        now = 0.1 * k
        if on_tick is not None:
            cloud = on_tick(k, c, cloud) if on_tick(k, c, cloud) is not None else cloud
        c.set_joint_state(q, now)
        c.set_scene(cloud, now)
        out = c.tick(now)
        outcomes.append(out)
        if out.command is not None:
            q = out.command
        states.append(q)
        if out.state == "failed" or (out.state == "reached" and reached(q, problem)[0]):
            break
    ok = reached(q, problem)[0] and not path_collides(problem, np.array(states))
    return ok, np.array(states), outcomes, c


@pytest.fixture(scope="module")
def stall_problem():
    return cluttered_problems(STALL_INDEX + 1, STALL_SEED)[STALL_INDEX]


@pytest.mark.slow
def test_a_goal_behind_an_obstacle_is_reached_by_following_a_plan_where_local_steps_stall(shipped_vae, stall_problem):
    ok_local, _, outcomes, _ = _run(shipped_vae, stall_problem, follow=False)
    assert not ok_local and all(o.values.get("command_source", "local") == "local" for o in outcomes)
    ok, states, outcomes, c = _run(shipped_vae, stall_problem, follow=True)
    assert ok, outcomes[-1].reason
    sources = [o.values.get("command_source") for o in outcomes]
    assert "plan" in sources and c.follower.plans["followed"] >= 1
    assert any("following the background plan" in o.reason for o in outcomes)
    assert outcomes[-1].state == "reached"


@pytest.mark.slow
def test_a_path_blocked_by_a_new_obstacle_is_dropped_and_never_commanded(shipped_vae, stall_problem):
    checker = _planner(shipped_vae)
    blocked = {}

    def add_obstacle(k, c, cloud):
        # once the arm follows the plan, put points on the rest of the path's end-effector way
        if "cloud" not in blocked and c.follower is not None and c.follower.following:
            stream = c.follower._stream
            q_mid = stream.reference(0.6 * stream.duration)
            ee = checker.panda.fk(q_mid).translation
            blob = ee + 0.03 * np.random.default_rng(0).standard_normal((200, 3))
            blocked["cloud"] = np.concatenate([cloud, blob])
        return blocked.get("cloud")

    ok, states, outcomes, c = _run(shipped_vae, stall_problem, follow=True, ticks=40, on_tick=add_obstacle)
    assert "cloud" in blocked
    assert c.follower.plans["dropped"] >= 1 and "collides in the newest scene" in c.follower.note + " ".join(
        o.values.get("plan_note", "") for o in outcomes
    )
    checker.backend.set_scene(blocked["cloud"])
    added = next(i for i, o in enumerate(outcomes) if o.values.get("command_source") == "plan") + 1
    for a, b in zip(states[added:-1], states[added + 1 :], strict=True):  # every command after it passes the check
        if not np.array_equal(a, b):
            assert checker.segment_free(a, b, c.follower.escape_from)


@pytest.mark.slow
def test_a_goal_changed_while_its_plan_runs_is_taken_up(shipped_vae, stall_problem):
    first_goal = Goal(np.array([0.45, -0.3, 0.5]), np.eye(3))
    runner = DeferredPlanRunner(planning_function(_planner(shipped_vae)))
    c = ClosedLoopController(_planner(shipped_vae), ClosedLoopConfig(), runner)
    c.set_joint_state(stall_problem.start_q, 0.0)
    c.set_scene(stall_problem.cloud, 0.0, cloud=stall_problem.cloud)
    c.set_goal(first_goal, 0.0)
    c.tick(0.0)  # plans the first goal (released only after its wall time)
    assert c.follower.plans["requested"] == 1 and runner.busy
    c.set_goal(stall_problem.goal, 0.0)  # changed before its plan arrived
    q = stall_problem.start_q.copy()
    for k in range(1, 100):
        now = 0.1 * k
        c.set_joint_state(q, now)
        c.set_scene(stall_problem.cloud, now)
        out = c.tick(now)
        if out.command is not None:
            q = out.command
        if out.state == "reached":
            break
    assert c.follower.plans["requested"] >= 2
    assert reached(q, stall_problem)[0], out.reason


def test_the_cameras_of_the_cloud_go_with_a_background_plan_to_amp_ls():
    """The closed loop's camera centres travel in the plan request, and `planning_function` hands them to a
    planner with an RRT escape (its seen-space search), not to one without."""
    seen = []

    class Fake:
        escape = object()

        def plan(self, q, goal, scene, eyes=None):
            seen.append(eyes)
            return "planned"

    eyes = np.array([[1.0, 0.0, 1.0], [0.0, 1.0, 1.0]])
    request = PlanRequest(Q_READY.copy(), Goal(np.array([0.5, 0.0, 0.4]), np.eye(3)), None, None, 1, eyes=eyes)
    assert planning_function(Fake(), reachability=False)(request) == "planned"
    np.testing.assert_array_equal(seen[-1], eyes)
    Fake.escape = None
    assert planning_function(Fake(), reachability=False)(request) == "planned"
    assert seen[-1] is None

    submitted = []

    class Runner:
        busy = False

        def poll(self, now):
            return None

        def submit(self, request, now):
            submitted.append(request)

    c = ClosedLoopController(Fake(), ClosedLoopConfig(), runner=Runner())
    c.set_cloud(np.zeros((3, 3)), 0.0, views=2, eyes=eyes)
    np.testing.assert_array_equal(c.cloud_eyes, eyes)
    assert c.follower is not None
    c.follower.update(0.0, Q_READY.copy(), request.goal, 0.0, 0.0, None, None, None, c.cloud_views, c.cloud_eyes)
    assert submitted and submitted[-1].views == 2
    np.testing.assert_array_equal(submitted[-1].eyes, eyes)

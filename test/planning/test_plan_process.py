"""Background plans in a child process: the plans of the same planner as in-process, a crashed child restarted, a
bad checkpoint refused with its reason, a parameter change without a new process, the runner's newest-wins order."""

import os
import signal
import time

import numpy as np
import pytest

from latent_planner_ros.planning.amp_ls import AmpLs, AmpLsConfig
from latent_planner_ros.planning.geometric_backend import GeometricBackend
from latent_planner_ros.planning.plan_process import PlanProcess, PlanProcessError, PlanSpec
from latent_planner_ros.planning.plan_runner import PlanRequest, ThreadedPlanRunner, planning_function
from latent_planner_ros.planning.problems import cluttered_problems, path_collides

SPEC = PlanSpec(AmpLsConfig(collision_backend="geometric"), "geometric")


@pytest.fixture(scope="module")
def process():
    p = PlanProcess()
    yield p
    p.close()


@pytest.fixture(scope="module")
def problems():
    return cluttered_problems(3, seed=4242)


def _request(problem, ident: int = 1) -> PlanRequest:
    return PlanRequest(problem.start_q, problem.goal, problem.cloud, None, ident)


@pytest.mark.slow
def test_a_plan_in_the_child_is_the_plan_of_the_same_planner_here(process, problems, shipped_vae):
    here = planning_function(AmpLs(shipped_vae, GeometricBackend(), SPEC.config))
    for k, problem in enumerate(problems):
        theirs, ours = process.plan_fn(SPEC)(_request(problem, k)), here(_request(problem, k))
        assert process.pid is not None and process.pid != os.getpid()
        # plans are budgeted in wall time (the escape starts after 0.25 s), so compare what they achieve
        assert ours.success and theirs.success, (ours.reason, theirs.reason)
        assert np.allclose(theirs.q_path[0], problem.start_q) and not path_collides(problem, theirs.q_path)
        assert theirs.info.keys() == ours.info.keys() and theirs.timings.keys() <= ours.timings.keys() | {"escape_s"}


@pytest.mark.slow
def test_a_child_that_dies_fails_its_plan_with_the_reason_and_is_restarted(process, problems):
    assert process.plan_fn(SPEC)(_request(problems[0])).q_path.shape[1] == 7
    pid, restarts = process.pid, process.restarts
    os.kill(pid, signal.SIGKILL)
    with pytest.raises(PlanProcessError, match="exited"):
        process.plan_fn(SPEC)(_request(problems[0]))
    result = process.plan_fn(SPEC)(_request(problems[0]))
    assert result.q_path.shape[1] == 7 and process.pid != pid and process.restarts == restarts + 1


@pytest.mark.slow
def test_a_bad_checkpoint_is_refused_with_its_reason_and_the_child_serves_on(process, problems, tmp_path):
    bad = PlanSpec(AmpLsConfig(), "learned", collision_checkpoint=str(tmp_path / "missing"))
    pid = process.pid
    with pytest.raises(PlanProcessError, match="CheckpointError.*missing"):
        process.plan_fn(bad)(_request(problems[0]))
    assert process.plan_fn(SPEC)(_request(problems[0])).q_path.shape[1] == 7
    assert pid is None or process.pid == pid  # the same child: an error in it is an answer, not an exit


@pytest.mark.slow
def test_a_changed_spec_rebuilds_in_the_same_child(process, problems):
    process.plan_fn(SPEC)(_request(problems[1]))
    pid = process.pid
    fewer = PlanSpec(AmpLsConfig(collision_backend="geometric", max_steps=300), "geometric")
    assert process.plan_fn(fewer)(_request(problems[1])).q_path.shape[1] == 7
    assert process.pid == pid


@pytest.mark.slow
def test_the_threaded_runner_on_the_process_never_blocks_and_the_newest_request_wins(process, problems):
    runner = ThreadedPlanRunner(process.plan_fn(SPEC))
    try:
        process.call(SPEC, None)  # built: the requests below plan, they do not wait for the child's imports
        for ident in (1, 2, 3):
            t0 = time.perf_counter()
            runner.submit(_request(problems[ident - 1], ident))
            assert runner.poll() is None or ident > 1
            assert time.perf_counter() - t0 < 0.05
        outcomes = []
        deadline = time.monotonic() + 60.0
        while runner.busy and time.monotonic() < deadline:
            outcome = runner.poll()
            if outcome is not None:
                outcomes.append(outcome)
            time.sleep(0.01)
        if (outcome := runner.poll()) is not None:
            outcomes.append(outcome)
        idents = [o.request.ident for o in outcomes]
        assert idents[-1] == 3 and 2 not in idents  # 3 replaced 2 while 1 ran
        assert all(o.error == "" and o.result is not None for o in outcomes)
    finally:
        runner.close()


def test_a_closed_process_refuses_plans():
    p = PlanProcess()
    p.close()
    with pytest.raises(PlanProcessError, match="closed"):
        p.call(SPEC, None)


def _unpicklable_answer(spec):
    return lambda request: lambda: None  # a local function does not pickle


@pytest.mark.slow
def test_an_answer_that_does_not_pickle_is_an_error_and_the_child_serves_on(problems, monkeypatch):
    import latent_planner_ros.planning.plan_process as plan_process

    conn_parent, conn_child = plan_process.multiprocessing.Pipe()
    monkeypatch.setattr(plan_process, "build_plan_fn", _unpicklable_answer)
    worker = plan_process.threading.Thread(target=plan_process._serve, args=(conn_child,), daemon=True)
    worker.start()
    conn_parent.send((SPEC, _request(problems[0])))
    assert conn_parent.poll(10.0), "no answer: the serving loop died on the unpicklable answer"
    answer = conn_parent.recv()
    assert isinstance(answer, plan_process._Raised) and "could not be sent" in answer.text
    conn_parent.send((SPEC, None))  # still serving
    assert conn_parent.recv() is None
    conn_parent.send(None)
    worker.join(5.0)
    assert not worker.is_alive()

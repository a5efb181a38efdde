"""Supervisor with plain Python processes: prefixed output, exit detection, readiness, escalating stop."""

from __future__ import annotations

import io
import signal
import subprocess
import sys
import threading
import time

import psutil
import pytest

from latent_planner_ros.processes.supervisor import ProcessSpec, StartupError, Supervisor, describe_exit

pytestmark = pytest.mark.timeout(60)


def py(name: str, code: str) -> ProcessSpec:
    return ProcessSpec(name, (sys.executable, "-u", "-c", code))


SLEEPER = "import time\nprint('hello', flush=True)\ntime.sleep(60)"
IGNORES_INT = (
    "import signal, time\nsignal.signal(signal.SIGINT, signal.SIG_IGN)\nprint('up', flush=True)\ntime.sleep(60)"
)
IGNORES_INT_TERM = (
    "import signal, time\nsignal.signal(signal.SIGINT, signal.SIG_IGN)\nsignal.signal(signal.SIGTERM, signal.SIG_IGN)\n"
    "print('up', flush=True)\ntime.sleep(60)"
)
FORKS = (
    "import subprocess, sys, time\n"
    "child = subprocess.Popen([sys.executable, '-c', 'import signal, time; "
    "signal.signal(signal.SIGINT, signal.SIG_IGN); time.sleep(60)'])\n"
    "print('child', child.pid, flush=True)\ntime.sleep(60)"
)


def make(*specs: ProcessSpec) -> tuple[Supervisor, io.StringIO, io.StringIO]:
    out, err = io.StringIO(), io.StringIO()
    return Supervisor(list(specs), stdout=out, stderr=err), out, err


def wait_for(predicate, timeout_s: float = 10.0) -> bool:
    end = time.monotonic() + timeout_s
    while not predicate() and time.monotonic() < end:
        time.sleep(0.05)
    return predicate()


def test_output_is_prefixed_and_tails_are_kept():
    suite, out, err = make(
        py("a", "import sys\nprint('one')\nprint('two', file=sys.stderr)"), py("b", "print('three')")
    )
    with suite:
        suite.start()
        assert wait_for(lambda: len(suite.exited()) == 2)
    assert "[a] one\n" in out.getvalue() and "[b] three\n" in out.getvalue()
    assert "[a] two\n" in err.getvalue() and "[launch] started a (pid" in err.getvalue()
    assert sorted(suite.tail("a")) == ["one", "two"]  # two readers: the order across streams is not kept


def test_names_must_be_unique():
    with pytest.raises(ValueError, match="unique"):
        Supervisor([py("a", "pass"), py("a", "pass")])


def test_exit_during_startup_names_the_process():
    suite, _, _ = make(py("good", SLEEPER), py("bad", "raise SystemExit(3)"))
    with suite:
        suite.start()
        with pytest.raises(StartupError, match="node bad exited with code 3 during start-up") as info:
            suite.wait_ready(lambda: set(), timeout_s=10.0)
        assert info.value.name == "bad"


def test_readiness_timeout_names_the_missing_process():
    suite, _, err = make(py("a", SLEEPER), py("b", SLEEPER))
    with suite:
        suite.start()
        with pytest.raises(StartupError, match=r"node b not up after 0.5 s"):
            suite.wait_ready(lambda: {"a"}, timeout_s=0.5)
    assert "[launch] a is up" in err.getvalue()


def test_watch_reports_the_first_exit_and_stop_ends_the_rest():
    suite, _, _ = make(py("long", SLEEPER), py("short", "import time\ntime.sleep(0.5)\nraise SystemExit(4)"))
    with suite:
        suite.start()
        assert suite.wait_ready(lambda: {"long", "short"}, timeout_s=5.0)
        assert suite.watch(threading.Event(), duration_s=20.0) == ("short", 4)
        pid = suite.pids["long"]
        codes = suite.stop()
    assert codes == {"long": -signal.SIGINT, "short": 4}  # an uncaught KeyboardInterrupt ends Python by SIGINT
    assert not psutil.pid_exists(pid)


def test_watch_ends_after_duration_or_stop_event():
    suite, _, _ = make(py("a", SLEEPER))
    with suite:
        suite.start()
        t0 = time.monotonic()
        assert suite.watch(threading.Event(), duration_s=0.5) is None
        assert 0.4 < time.monotonic() - t0 < 3.0
        stop = threading.Event()
        threading.Timer(0.3, stop.set).start()
        assert suite.watch(stop) is None


def test_stop_escalates_to_sigterm_and_sigkill():
    suite, out, err = make(py("int", IGNORES_INT), py("intterm", IGNORES_INT_TERM))
    suite.start()
    assert wait_for(lambda: out.getvalue().count("up") == 2)
    t0 = time.monotonic()
    codes = suite.stop(sigint_timeout_s=0.5, sigterm_timeout_s=0.5)
    assert time.monotonic() - t0 < 5.0
    assert codes == {"int": -signal.SIGTERM, "intterm": -signal.SIGKILL}
    assert "sending SIGTERM" in err.getvalue() and "intterm still running: sending SIGKILL" in err.getvalue()
    assert describe_exit(codes["intterm"]) == "signal SIGKILL"


def test_force_skips_the_grace_periods():
    suite, out, _ = make(py("stubborn", IGNORES_INT_TERM))
    suite.start()
    assert wait_for(lambda: "up" in out.getvalue())
    force = threading.Event()
    force.set()
    t0 = time.monotonic()
    assert suite.stop(sigint_timeout_s=30.0, sigterm_timeout_s=30.0, force=force) == {"stubborn": -signal.SIGKILL}
    assert time.monotonic() - t0 < 5.0


def test_stop_leaves_no_process_of_the_group_behind():
    suite, out, _ = make(py("parent", FORKS))
    suite.start()
    assert wait_for(lambda: "child" in out.getvalue())
    child = int(out.getvalue().split("child")[1].split()[0])
    assert psutil.pid_exists(child)
    suite.stop(sigint_timeout_s=2.0)
    assert wait_for(lambda: not psutil.pid_exists(child) or psutil.Process(child).status() == "zombie", 5.0)


def test_a_missing_program_is_a_startup_error():
    suite, _, _ = make(ProcessSpec("ghost", ("/nonexistent/program",)))
    with pytest.raises(StartupError, match="node ghost could not be started"):
        suite.start()


def test_children_stop_on_sigint_even_when_the_supervisor_ignores_it():
    """A supervisor started as a background job of a non-interactive shell inherits SIGINT ignored; its
    children must still end gracefully on the SIGINT of stop()."""
    code = (
        "import signal, sys\n"
        "signal.signal(signal.SIGINT, signal.SIG_IGN)\n"
        "from latent_planner_ros.processes.supervisor import ProcessSpec, Supervisor\n"
        f"suite = Supervisor([ProcessSpec('long', (sys.executable, '-u', '-c', {SLEEPER!r}))])\n"
        "suite.start()\n"
        "assert suite.wait_ready(lambda: {'long'} if suite.tail('long') else set(), timeout_s=10.0)\n"
        "print('CODES', suite.stop(sigint_timeout_s=10.0))\n"
    )
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=50)
    assert f"CODES {{'long': {-signal.SIGINT}}}" in proc.stdout, proc.stdout + proc.stderr

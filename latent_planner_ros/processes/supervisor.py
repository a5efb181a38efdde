"""Process supervision for a suite of nodes: start, prefix output, wait until up, watch, stop. No ROS here.

Each process runs in its own process group, so a signal reaches the node and anything it started, and
a Ctrl-C in the terminal reaches only the supervisor, which then stops the suite in order:
SIGINT to every group, SIGTERM to the groups still alive after a grace period, then SIGKILL.
Every line a process writes is echoed with a ``[name] `` prefix (stdout to stdout, stderr to stderr).

    specs = [ProcessSpec("sim", (sys.executable, "-m", "latent_planner_ros", "run", "sim"))]
    with Supervisor(specs) as suite:
        suite.start()
        suite.wait_ready(lambda: graph_node_names(), timeout_s=60.0)
        exited = suite.watch(stop_event, duration_s=10.0)  # (name, code) if one died, else None
"""

from __future__ import annotations

import collections
import os
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import IO, TextIO

POLL_S = 0.1
"""Interval [s] at which processes and the readiness check are polled."""


@dataclass(frozen=True)
class ProcessSpec:
    """One process of the suite.

    Attributes:
        name: unique name; the output prefix, and the node name the readiness check looks for.
        argv: the command line (program first).
        env: the complete environment of the process; None inherits the supervisor's.
        cwd: working directory; None inherits the supervisor's.
    """

    name: str
    argv: tuple[str, ...]
    env: Mapping[str, str] | None = None
    cwd: str | None = None


class StartupError(RuntimeError):
    """A process could not be started, died, or was not up in time during start-up.

    Attributes:
        name: the process at fault.
    """

    def __init__(self, name: str, message: str):
        super().__init__(message)
        self.name = name


def describe_exit(returncode: int) -> str:
    """'code 3' for an exit status, 'signal SIGKILL' for a process killed by a signal (negative code)."""
    if returncode < 0:
        try:
            return f"signal {signal.Signals(-returncode).name}"
        except ValueError:
            return f"signal {-returncode}"
    return f"code {returncode}"


class _Running:
    """A started process, its output readers and the last lines it wrote."""

    def __init__(self, spec: ProcessSpec, popen: subprocess.Popen, tail_lines: int):
        self.spec = spec
        self.popen = popen
        self.tail: collections.deque[str] = collections.deque(maxlen=tail_lines)
        self.readers: list[threading.Thread] = []


def _default_sigint() -> None:
    """In a child before exec: SIGINT at its default action, even if this process ignores it (as a background
    job of a non-interactive shell does); stop() relies on SIGINT ending the children gracefully."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)


class Supervisor:
    """Runs a list of processes as one suite (see the module docstring).

    Args:
        specs: the processes, started in this order.
        stdout, stderr: where prefixed output goes (default: sys.stdout, sys.stderr at write time).
        tail_lines: how many of each process's last output lines :meth:`tail` keeps.
        label: prefix of the supervisor's own messages.
    """

    def __init__(
        self,
        specs: Sequence[ProcessSpec],
        *,
        stdout: TextIO | None = None,
        stderr: TextIO | None = None,
        tail_lines: int = 40,
        label: str = "launch",
    ):
        names = [s.name for s in specs]
        duplicates = sorted({n for n in names if names.count(n) > 1})
        if duplicates:
            raise ValueError(f"process names must be unique, repeated: {duplicates}")
        self.specs = list(specs)
        self.label = label
        self._stdout = stdout
        self._stderr = stderr
        self._tail_lines = tail_lines
        self._lock = threading.RLock()
        self._running: dict[str, _Running] = {}

    # ------------------------------------------------------------------ output
    def _write(self, stream: TextIO | None, default: str, text: str) -> None:
        out = stream if stream is not None else getattr(sys, default)
        with self._lock:  # reentrant: a signal handler may log while the main thread writes
            try:
                out.write(text)
                out.flush()
            except (OSError, ValueError):  # closed or broken output: keep draining the pipes anyway
                pass

    def log(self, message: str) -> None:
        """Write one of the supervisor's own messages (to stderr, prefixed with ``[label]``)."""
        self._write(self._stderr, "stderr", f"[{self.label}] {message}\n")

    def _pump(self, run: _Running, pipe: IO[bytes], to_stderr: bool) -> None:
        prefix = f"[{run.spec.name}] "
        with pipe:
            for raw in iter(pipe.readline, b""):
                line = raw.decode("utf-8", errors="replace").rstrip("\r\n")
                run.tail.append(line)
                if to_stderr:
                    self._write(self._stderr, "stderr", prefix + line + "\n")
                else:
                    self._write(self._stdout, "stdout", prefix + line + "\n")

    # ------------------------------------------------------------------ start and watch
    def start(self) -> None:
        """Start every process (each in a new process group). Raises StartupError if one cannot be executed."""
        for spec in self.specs:
            try:
                popen = subprocess.Popen(
                    list(spec.argv),
                    env=None if spec.env is None else dict(spec.env),
                    cwd=spec.cwd,
                    stdin=subprocess.DEVNULL,
                    stdout=subprocess.PIPE,
                    stderr=subprocess.PIPE,
                    process_group=0,
                    preexec_fn=_default_sigint,
                )
            except OSError as err:
                self.stop()
                raise StartupError(spec.name, f"node {spec.name} could not be started: {err}") from None
            run = _Running(spec, popen, self._tail_lines)
            for pipe, to_stderr in ((popen.stdout, False), (popen.stderr, True)):
                thread = threading.Thread(
                    target=self._pump, args=(run, pipe, to_stderr), name=f"output-{spec.name}", daemon=True
                )
                thread.start()
                run.readers.append(thread)
            self._running[spec.name] = run
            self.log(f"started {spec.name} (pid {popen.pid})")

    @property
    def pids(self) -> dict[str, int]:
        """Process id of every started process, by name."""
        return {name: run.popen.pid for name, run in self._running.items()}

    def tail(self, name: str) -> list[str]:
        """The last lines (without prefix) that process `name` wrote."""
        return list(self._running[name].tail)

    def exited(self) -> dict[str, int]:
        """Return code of every started process that has ended, by name (in start order)."""
        codes = {name: run.popen.poll() for name, run in self._running.items()}
        return {name: code for name, code in codes.items() if code is not None}

    def wait_ready(
        self,
        up: Callable[[], Iterable[str]],
        timeout_s: float,
        stop: threading.Event | None = None,
    ) -> bool:
        """Wait until every process's name is in ``up()`` (e.g. the node names of the ROS graph).

        Args:
            up: returns the names that are up now; polled every POLL_S.
            timeout_s: [s] longest wait.
            stop: when set (e.g. by Ctrl-C), the wait ends early.

        Returns:
            True when all are up, False when `stop` was set first.

        Raises:
            StartupError: naming a process that exited meanwhile, or the first one not up after `timeout_s`.
        """
        t0 = time.monotonic()
        pending = [s.name for s in self.specs]
        while True:
            for name, code in self.exited().items():
                raise StartupError(name, f"node {name} exited with {describe_exit(code)} during start-up")
            if stop is not None and stop.is_set():
                return False
            seen = set(up())
            for name in [n for n in pending if n in seen]:
                pending.remove(name)
                self.log(f"{name} is up ({time.monotonic() - t0:.1f} s)")
            if not pending:
                return True
            if time.monotonic() - t0 > timeout_s:
                raise StartupError(pending[0], f"node {pending[0]} not up after {timeout_s:g} s")
            time.sleep(POLL_S)

    def watch(self, stop: threading.Event, duration_s: float | None = None) -> tuple[str, int] | None:
        """Block until a process exits, `stop` is set, or `duration_s` [s] has passed.

        Returns:
            (name, return code) of the first process found ended, or None if stopped or out of time.
        """
        end = None if duration_s is None else time.monotonic() + duration_s
        while not stop.is_set():
            for name, code in self.exited().items():
                return name, code
            if end is not None and time.monotonic() >= end:
                return None
            stop.wait(POLL_S)
        return None

    # ------------------------------------------------------------------ stop
    def _signal_groups(self, sig: int, names: Iterable[str]) -> None:
        for name in names:
            try:
                os.killpg(self._running[name].popen.pid, sig)
            except (ProcessLookupError, PermissionError):
                pass

    def _wait_all(self, names: list[str], timeout_s: float, force: threading.Event | None) -> list[str]:
        """Wait up to timeout_s for `names` to end (less if `force` is set); returns those still running."""
        end = time.monotonic() + timeout_s
        alive = [n for n in names if self._running[n].popen.poll() is None]
        while alive and time.monotonic() < end and not (force is not None and force.is_set()):
            time.sleep(0.05)
            alive = [n for n in alive if self._running[n].popen.poll() is None]
        return alive

    def stop(
        self,
        sigint_timeout_s: float = 10.0,
        sigterm_timeout_s: float = 5.0,
        force: threading.Event | None = None,
    ) -> dict[str, int]:
        """Stop every process that is still running: SIGINT, then SIGTERM, then SIGKILL to its group.

        Args:
            sigint_timeout_s: [s] grace period after SIGINT.
            sigterm_timeout_s: [s] grace period after SIGTERM.
            force: when set (e.g. by a second Ctrl-C), the grace periods end at once.

        Returns:
            the return code of every started process, by name.
        """
        alive = [n for n, run in self._running.items() if run.popen.poll() is None]
        for sig, timeout_s in ((signal.SIGINT, sigint_timeout_s), (signal.SIGTERM, sigterm_timeout_s)):
            if not alive:
                break
            if sig != signal.SIGINT:
                self.log(f"{', '.join(alive)} still running: sending {sig.name}")
            self._signal_groups(sig, alive)
            alive = self._wait_all(alive, timeout_s, force)
        if alive:
            self.log(f"{', '.join(alive)} still running: sending SIGKILL")
        # Every group gets a SIGKILL: it ends the processes still running and anything a node started
        # that outlived it (an empty group is skipped by the kernel).
        self._signal_groups(signal.SIGKILL, list(self._running))
        for run in self._running.values():
            try:
                run.popen.wait(timeout=5.0)
            except subprocess.TimeoutExpired:
                self.log(f"{run.spec.name} (pid {run.popen.pid}) did not end after SIGKILL")
            for reader in run.readers:
                reader.join(timeout=2.0)
        return {name: run.popen.returncode for name, run in self._running.items()}

    def __enter__(self) -> Supervisor:
        return self

    def __exit__(self, *exc) -> None:
        self.stop()

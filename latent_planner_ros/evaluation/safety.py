"""The safety invariant of joint commands, checked against the arm's measured state. No ROS.

Every ``joint_command`` must

1. name the seven arm joints once each (``panda_joint1..7``; other joints are ignored), with finite positions,
2. lie inside the joint limits ``[Q_MIN, Q_MAX]`` (robot.limits),
3. be reachable from the measured state at the Panda's velocity limits within one command period:
   ``|q_cmd - q_measured| <= V_MAX * command_period_s + slack_rad`` for every joint.

"The measured state" is the ground truth the monitor sees (a driver's, or the sim's ``joint_states``), not
what the planner received: a command is checked against every state measured within ``latency_s`` before it
(and the last one before that window) and passes if any of them is close enough, because a planner computes
its command from a state that reached it one transport delay earlier. A known jump of the measured state (a
sim reset teleports the arm; a real arm cannot jump) is announced with ``note_jump``: for ``jump_grace_s``
after it, commands may still answer the states measured before it. ``slack_rad`` covers the motion during
that delay and the arm's tracking error (documented default 0.02 rad; the planner itself steps at most
``speed_scale`` = 0.5 of the limit per period, so a compliant planner stays far inside the bound).

    monitor = SafetyMonitor()
    monitor.on_state(t, q)                                       # (7,) [rad], measured, at time t [s]
    violations = monitor.on_command(t, msg.name, msg.position)   # [] when the command is safe
    monitor.summary()                                            # counts, JSON-ready
"""

from __future__ import annotations

import collections
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from latent_planner_ros.robot.limits import JOINT_NAMES, Q_MAX, Q_MIN, V_MAX

KINDS = ("malformed", "non_finite", "joint_limit", "velocity")
"""Kinds of violation, in the order they are checked (a command gets at most one)."""


@dataclass(frozen=True)
class SafetyConfig:
    """Bounds of the invariant.

    Attributes:
        command_period_s: [s] the planner's command period (10 Hz).
        slack_rad: [rad] added to V_MAX * command_period_s: transport delay and tracking error.
        latency_s: [s] a command may answer any state measured this long before it.
        jump_grace_s: [s] after a jump of the measured state, commands may answer the states before it this long.
        limit_tol_rad: [rad] rounding tolerance of the joint-limit check.
    """

    command_period_s: float = 0.1
    slack_rad: float = 0.02
    latency_s: float = 0.15
    jump_grace_s: float = 0.5
    limit_tol_rad: float = 1e-6

    @property
    def step_bound(self) -> np.ndarray:
        """(7,) [rad] the largest allowed distance from the measured state per joint."""
        return V_MAX * self.command_period_s + self.slack_rad


@dataclass(frozen=True)
class Violation:
    """One command that broke the invariant: when [s], which rule (one of KINDS), and the numbers."""

    time: float
    kind: str
    detail: str


def command_positions(names: Sequence[str], positions: Sequence[float]) -> np.ndarray:
    """The arm joints' positions (7,) [rad] of a JointState-like command, in JOINT_NAMES order.

    Raises:
        ValueError: a missing or repeated arm joint, or len(positions) != len(names).
    """
    names = list(names)
    if len(positions) != len(names):
        raise ValueError(f"{len(names)} names but {len(positions)} positions")
    index = {}
    for i, n in enumerate(names):
        if n in index:
            raise ValueError(f"joint {n!r} named twice")
        index[n] = i
    missing = [n for n in JOINT_NAMES if n not in index]
    if missing:
        raise ValueError(f"joints {missing} missing")
    return np.array([positions[index[n]] for n in JOINT_NAMES], dtype=float)


class SafetyMonitor:
    """Checks commands (see the module docstring) and counts what it saw. Times [s] on one clock.

    Attributes:
        commands: commands checked; unchecked_velocity: of those, commands with no measured state yet
            (the velocity rule cannot be applied); violations: every Violation, in order.
    """

    def __init__(self, config: SafetyConfig | None = None, history: int = 256):
        self.config = config or SafetyConfig()
        self._states: collections.deque[tuple[float, np.ndarray]] = collections.deque(maxlen=history)
        self.commands = 0
        self.unchecked_velocity = 0
        self.max_step_ratio = 0.0
        self.violations: list[Violation] = []
        self._jump: float | None = None

    def on_state(self, t: float, q: np.ndarray) -> None:
        """A measured joint state q (7,) [rad] at time t [s]."""
        q = np.asarray(q, dtype=float)
        if q.shape == (7,) and np.all(np.isfinite(q)):
            self._states.append((float(t), q.copy()))

    def note_jump(self, t: float) -> None:
        """The measured state jumps at time t [s] (e.g. a sim reset): see the module docstring."""
        self._jump = float(t)

    def _recent(self, t: float) -> list[np.ndarray]:
        """The states measured within latency_s before t, and the last one before that window."""
        window = self.config.latency_s
        if self._jump is not None and self._jump <= t <= self._jump + self.config.jump_grace_s:
            window = t - self._jump + self.config.latency_s
        recent, before = [], None
        for ts, q in self._states:
            if ts > t:
                continue
            if ts >= t - window:
                recent.append(q)
            else:
                before = q
        return recent + ([before] if before is not None else [])

    def on_command(self, t: float, names: Sequence[str], positions: Sequence[float]) -> list[Violation]:
        """Check a command received at time t [s]; returns the violation found ([] if none)."""
        self.commands += 1
        found = self._check(t, names, positions)
        if found is not None:
            self.violations.append(found)
            return [found]
        return []

    def _check(self, t: float, names: Sequence[str], positions: Sequence[float]) -> Violation | None:
        cfg = self.config
        try:
            q = command_positions(names, positions)
        except ValueError as err:
            return Violation(t, "malformed", str(err))
        if not np.all(np.isfinite(q)):
            return Violation(t, "non_finite", f"command {q.tolist()}")
        low, high = q < Q_MIN - cfg.limit_tol_rad, q > Q_MAX + cfg.limit_tol_rad
        if np.any(low | high):
            joints = [JOINT_NAMES[i] for i in np.flatnonzero(low | high)]
            return Violation(t, "joint_limit", f"{joints} outside the limits: {np.round(q, 4).tolist()}")
        measured = self._recent(t)
        if not measured:
            self.unchecked_velocity += 1
            return None
        ratios = [float(np.max(np.abs(q - m) / cfg.step_bound)) for m in measured]
        best = min(ratios)
        self.max_step_ratio = max(self.max_step_ratio, best)
        if best > 1.0:
            m = measured[int(np.argmin(ratios))]
            step = np.abs(q - m)
            j = int(np.argmax(step / cfg.step_bound))
            return Violation(
                t,
                "velocity",
                f"{JOINT_NAMES[j]} commanded {step[j]:.3f} rad from the measured state, bound {cfg.step_bound[j]:.3f}",
            )
        return None

    def counts(self) -> dict[str, int]:
        """Violations by kind (every kind listed, zeros included)."""
        return {k: sum(v.kind == k for v in self.violations) for k in KINDS}

    def summary(self) -> dict:
        """JSON-ready: commands, violations (total and by kind), unchecked, the largest step / bound ratio."""
        return {
            "commands": self.commands,
            "violations": len(self.violations),
            "by_kind": self.counts(),
            "unchecked_velocity": self.unchecked_velocity,
            "max_step_ratio": round(self.max_step_ratio, 4),
            "first": [f"{v.kind}: {v.detail}" for v in self.violations[:5]],
        }

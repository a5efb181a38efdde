"""The arm's joint-position command interface: validation, clamping, interpolation, velocity limit, hold.

A new target q (7,) [rad] is clamped into [Q_MIN, Q_MAX] and reached by moving the actuators' setpoint
in a straight line over ``period`` seconds (the expected command period: 10 Hz targets then give a smooth,
continuous motion), never faster than ``velocity_scale * V_MAX`` per joint. Without a fresh command for
``timeout`` seconds the setpoint stops where it is (the arm holds); timeout 0 keeps the last target.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from latent_planner_ros.robot.limits import JOINT_NAMES, Q_MAX, Q_MIN, V_MAX


@dataclass(frozen=True)
class CommandResult:
    """Outcome of a command.

    Attributes:
        accepted: False when the command was refused (the arm keeps its previous target).
        clamped: True when some joints were moved into their limits.
        reason: why it was refused or clamped ('' when accepted as is).
    """

    accepted: bool
    clamped: bool = False
    reason: str = ""


class JointCommand:
    """Turns sporadic position targets into a smooth, rate-limited actuator setpoint.

    Args:
        q0: (7,) [rad] initial setpoint and target.
        period: [s] time over which a new target is approached linearly (0: as fast as allowed).
        timeout: [s] hold where the setpoint is when no command came for this long (0: never).
        velocity_scale: fraction of V_MAX the setpoint may move at, in (0, 1].
    """

    def __init__(self, q0: np.ndarray, period: float = 0.1, timeout: float = 1.0, velocity_scale: float = 1.0):
        self.period = float(period)
        self.timeout = float(timeout)
        self.v_max = V_MAX * float(velocity_scale)
        self.reset(q0)

    def reset(self, q0: np.ndarray) -> None:
        """Setpoint and target to q0 (7,) [rad] (clamped), no command pending."""
        self.setpoint = np.clip(np.asarray(q0, dtype=float), Q_MIN, Q_MAX)
        self.target = self.setpoint.copy()
        self.rate = self.v_max.copy()
        self.last_command_time: float | None = None

    def set(self, q: np.ndarray, time: float) -> CommandResult:
        """A new target q (7,) [rad] at simulation time [s]; NaN/inf or a wrong shape is refused."""
        q = np.asarray(q, dtype=float)
        if q.shape != (7,):
            return CommandResult(False, reason=f"expected 7 joint positions, got shape {q.shape}")
        if not np.all(np.isfinite(q)):
            bad = [n for n, ok in zip(JOINT_NAMES, np.isfinite(q), strict=True) if not ok]
            return CommandResult(False, reason=f"NaN or inf position for {bad}")
        clamped = np.clip(q, Q_MIN, Q_MAX)
        outside = [n for n, a, b in zip(JOINT_NAMES, q, clamped, strict=True) if a != b]
        self.target = clamped
        step = np.abs(self.target - self.setpoint)
        self.rate = np.minimum(step / self.period, self.v_max) if self.period > 0 else self.v_max.copy()
        self.last_command_time = float(time)
        if outside:
            return CommandResult(True, clamped=True, reason=f"clamped into the joint limits: {outside}")
        return CommandResult(True)

    def advance(self, time: float, dt: float) -> np.ndarray:
        """Move the setpoint by one step dt [s] at simulation time [s]; returns it (7,) [rad]."""
        stale = self.last_command_time is not None and self.timeout > 0 and time - self.last_command_time > self.timeout
        if stale:  # no fresh command: hold where the reference is now
            self.target = self.setpoint.copy()
            self.last_command_time = None
        delta = np.clip(self.target - self.setpoint, -self.rate * dt, self.rate * dt)
        self.setpoint = self.setpoint + delta
        return self.setpoint

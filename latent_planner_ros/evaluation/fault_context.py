"""What a fault-injection case works with: its result record and a context of checks and waits. No rclpy.

:class:`Ctx` wraps a running :class:`~latent_planner_ros.evaluation.fault_suite.FaultSuite` and its probe: it
records the case's checks, waits for texts on the nodes' status topics and logs, and tells whether the planner
operates normally (a fresh goal, A and B alternating, reached while commanding at the control rate).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from latent_planner_ros.evaluation.fault_inputs import box_cloud, goal_pose
from latent_planner_ros.evaluation.fault_suite import FaultSuite
from latent_planner_ros.planning.closed_loop import ClosedLoopConfig

STALE_JOINTS_S = ClosedLoopConfig().stale_joint_states_s
STALE_SCENE_S = ClosedLoopConfig().stale_scene_s
PERIOD_S = 1.0 / ClosedLoopConfig().rate_hz
HELD_RAD = 0.01
"""[rad] an arm that moves less than this per joint over a window is holding."""
REACH_TIMEOUT_S = 25.0
"""[s] longest wait for the arm to reach a fresh goal when checking that operation resumed."""


@dataclass
class CaseResult:
    """The outcome of one case: checks by label (True = passed), notes, wall time [s], violations."""

    name: str
    group: str
    survived: bool = False
    checks: dict[str, bool] = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)
    duration_s: float = 0.0
    violations: int = 0

    def failures(self) -> list[str]:
        return [label for label, ok in self.checks.items() if not ok]

    def to_dict(self) -> dict:
        return {
            "name": self.name,
            "group": self.group,
            "survived": self.survived,
            "checks": self.checks,
            "notes": self.notes,
            "duration_s": round(self.duration_s, 2),
            "violations": self.violations,
        }


class Ctx:
    """What a case works with: the suite, its probe, check bookkeeping and waiting helpers."""

    def __init__(self, suite: FaultSuite | None, group: str):
        self.suite = suite
        self.probe = suite.probe if suite is not None else None
        self.group = group
        self.backend = suite.plan.backend if suite is not None else ""
        self.scene = box_cloud()
        self.figures: dict = {}
        self.result: CaseResult | None = None
        self._goal = 0

    # -- bookkeeping ---------------------------------------------------------------------------
    def check(self, label: str, ok: bool, detail: str = "") -> bool:
        self.result.checks[label] = bool(ok)
        if detail or not ok:
            self.result.notes.append(f"{label}: {'ok' if ok else 'FAILED'}{' - ' + detail if detail else ''}")
        return bool(ok)

    def note(self, text: str) -> None:
        self.result.notes.append(text)

    # -- waiting -------------------------------------------------------------------------------
    @staticmethod
    def wait(pred: Callable[[], bool], timeout_s: float, poll_s: float = 0.05) -> bool:
        end = time.monotonic() + timeout_s
        while True:
            if pred():
                return True
            if time.monotonic() > end:
                return False
            time.sleep(poll_s)

    def seen(self, text: str, since: float, nodes=("planner", "scene_encoder"), timeout_s: float = 3.0) -> bool:
        """Whether `text` appears in a status (message or key=value) or a /rosout line of `nodes` after `since`."""

        def found() -> bool:
            for node in nodes:
                if any(text in s.text() for s in self.probe.statuses_since(node, since)):
                    return True
            return any(name in nodes and text in msg for _, name, _, msg in self.probe.logs_since(since))

        return self.wait(found, timeout_s)

    def value_seen(self, key: str, pred: Callable[[str], bool], since: float, node="planner", timeout_s=3.0) -> bool:
        """Whether a status of `node` after `since` has values[key] satisfying pred."""
        return self.wait(
            lambda: any(key in s.values and pred(s.values[key]) for s in self.probe.statuses_since(node, since)),
            timeout_s,
        )

    def state(self) -> str:
        """The planner's latest reported state ("" before any status)."""
        recent = self.probe.statuses_since("planner", time.monotonic() - 1.0)
        return recent[-1].values.get("state", "") if recent else ""

    def command_rate(self, window_s: float = 1.0) -> float:
        """Commands per second over the last window_s."""
        return len(self.probe.commands_since(time.monotonic() - window_s)) / window_s

    def last_command_stamp(self) -> float | None:
        """Header stamp [s] of the latest command (the planner's clock when it was sent)."""
        cmds = self.probe.commands_since(0.0)
        return cmds[-1][2] if cmds else None

    def arm_motion(self, since: float, until: float | None = None) -> float:
        """Largest joint excursion [rad] of the measured arm over [since, until]."""
        qs = [q for t, q in self.probe.measured_since(since) if until is None or t <= until]
        if len(qs) < 2:
            return 0.0
        qs = np.asarray(qs)
        return float(np.max(qs.max(axis=0) - qs.min(axis=0)))

    def next_goal(self) -> str:
        self._goal += 1
        name = "AB"[self._goal % 2]
        self.probe.set_goal(goal_pose(name))
        return name

    def operating(self, timeout_s: float = REACH_TIMEOUT_S, new_goal: bool = True) -> bool:
        """Send a fresh goal (A and B alternate) and wait until the planner reports it reached while
        commanding at its rate: normal operation."""
        if new_goal:
            self.next_goal()
        t0 = time.monotonic()

        def ok() -> bool:  # tracking (the new goal is being pursued), then reached
            states = [s.values.get("state") for s in self.probe.statuses_since("planner", t0)]
            reached = "tracking" in states and "reached" in states[states.index("tracking") :]
            return reached and self.command_rate() >= 0.7 / PERIOD_S

        return self.wait(ok, timeout_s, poll_s=0.1)

    def moving(self, timeout_s: float = 2.0) -> bool:
        """Send a fresh goal and wait until the planner tracks it (the arm is on its way)."""
        self.next_goal()
        t0 = time.monotonic()
        return self.wait(
            lambda: any(s.values.get("state") == "tracking" for s in self.probe.statuses_since("planner", t0 + 0.1)),
            timeout_s,
        )

    def resumes(self, label: str = "operation resumes") -> bool:
        t0 = time.monotonic()
        ok = self.operating()
        return self.check(
            label, ok, f"goal reached {time.monotonic() - t0:.1f} s after recovery" if ok else self.story(t0)
        )

    def story(self, since: float) -> str:
        """What the planner reported since `since`: its states in order with their counts, its last status
        values (cut at 300 characters) and the current command rate, for the message of a failed check."""
        statuses = self.probe.statuses_since("planner", since)
        runs: list[list] = []
        for s in statuses:
            state = s.values.get("state", "?")
            if runs and runs[-1][0] == state:
                runs[-1][1] += 1
            else:
                runs.append([state, 1])
        states = ", ".join(f"{state} x{n}" for state, n in runs) or "no status"
        last = str(statuses[-1].values)[:300] if statuses else "-"
        return f"planner states: {states}; last status: {last}; {self.command_rate():.0f} commands/s"

    def holds_after(self, since: float, what: str, timeout_s: float) -> bool:
        """Check that the planner reports holding (`what` in its status) and that the arm then stays put."""
        ok = self.seen(what, since, ("planner",), timeout_s)
        self.check(f"planner reports '{what}'", ok)
        if ok:
            t = time.monotonic()
            time.sleep(0.6)
            motion = self.arm_motion(t + 0.1)
            self.check("arm holds", motion < HELD_RAD, f"moved {motion:.4f} rad in 0.5 s")
        return ok

"""The fault-injection cases, shared by ``test/faults`` and ``bench faults``.

A case injects one fault into the running suite (see ``fault_suite``), checks the nodes' reaction, removes
the fault and checks that normal operation resumes. Every case also checks that no node crashed and that
the safety invariant (``evaluation.safety``) held for every ``joint_command`` during the case. A case
survives when all its checks pass.

Cases come in groups that share one suite start-up:

- ``inputs`` (geometric backend pinned: these cases do not depend on it; probe as arm and camera):
  bad goals, faulty and silent ``joint_states``, bad and valid runtime parameters.
- ``scene`` (the configured backend; with the learned one the scene_encoder runs): the load figure (planner
  tick p99 while 100k-point clouds arrive at 30 Hz), malformed, empty and huge ``camera/points``, the camera
  going silent, the planner and the scene_encoder killed and restarted.
- ``sim`` (the sim instead of the probe's arm): a sim reset in mid-motion.
- ``startup`` (single processes, ``fault_startup``): missing, corrupt and mismatched checkpoints and bad
  parameters at start: a clear error and a non-zero exit.

    results, info = run_group("inputs", log_path="out/faults_nodes.log")
"""

from __future__ import annotations

import sys
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from latent_planner_ros.evaluation.fault_context import (
    HELD_RAD,
    PERIOD_S,
    STALE_JOINTS_S,
    STALE_SCENE_S,
    CaseResult,
    Ctx,
)
from latent_planner_ros.evaluation.fault_inputs import (
    BOX_CENTRE,
    JOINT_STATE_FAULTS,
    bad_goals,
    box_cloud,
    goal_pose,
    malformed_clouds,
    pose_at,
    random_cloud,
)
from latent_planner_ros.evaluation.fault_startup import run_startup_group
from latent_planner_ros.evaluation.fault_suite import FaultSuite, plan_fault_suite
from latent_planner_ros.evaluation.stats import percentile
from latent_planner_ros.nodes.planner_config import PlannerNodeConfig
from latent_planner_ros.planning.closed_loop import ClosedLoopConfig
from latent_planner_ros.processes.supervisor import StartupError

LOAD_POINTS, LOAD_RATE_HZ, LOAD_S = 100_000, 30.0, 10.0
"""The load case: clouds of this many points at this rate [Hz] for this long [s] (after as long at rest)."""
HUGE_POINTS = 2_000_000
GIVE_UP_S = 3.0
"""[s] the planner's no-progress limit while it chases a goal inside an unobserved box interior."""


# ---------------------------------------------------------------------------------------------- cases
def _cloud_case(name: str) -> Callable[[Ctx], None]:
    def run(ctx: Ctx) -> None:
        msg, text = malformed_clouds(ctx.scene)[name]
        n = int(ctx.scene.width)
        t0 = time.monotonic()
        ctx.probe.set_cloud(msg)
        if text:
            ctx.check("refusal reason on status/logs", ctx.seen(text, t0))
            ctx.holds_after(t0, "holding: scene", STALE_SCENE_S + 2.0)
            if ctx.backend == "learned":
                ctx.check("scene_encoder reports the refusal", ctx.seen(text, t0, ("scene_encoder",)))
        else:
            used = {"cloud_nan_points": 0, "cloud_inf_points": n - (n + 2) // 3, "cloud_zero_points": 0}[name]
            received = 0 if name == "cloud_zero_points" else n
            ok = ctx.value_seen("cloud_points_used", lambda v: v == str(used), t0) and ctx.value_seen(
                "cloud_points_in", lambda v: v == str(received), t0
            )
            ctx.check(f"planner status reports {received} points in, {used} used", ok)
            if ctx.backend == "learned":
                expect = "empty cloud" if used == 0 else f"encoded {used} points"
                ctx.check(f"scene_encoder reports '{expect}'", ctx.seen(expect, t0, ("scene_encoder",)))
            time.sleep(0.5)
            ctx.check("commands continue", ctx.command_rate() >= 0.5 / PERIOD_S)
        ctx.probe.set_cloud(ctx.scene)
        ctx.resumes()

    return run


def huge_cloud(ctx: Ctx) -> None:
    """2 million points (24 MB), once a second for 3 s."""
    from msg_adapters import xyz_to_cloud

    pts = np.random.default_rng(1).uniform([0.0, -0.6, 0.0], [1.0, 0.6, 0.5], size=(HUGE_POINTS, 3))
    big = xyz_to_cloud(pts.astype(np.float32))
    t0 = time.monotonic()
    ctx.probe.set_cloud(big, rate_hz=1.0)
    limit = PlannerNodeConfig().cloud_max_points
    ok = ctx.value_seen("cloud_points_in", lambda v: v == str(HUGE_POINTS), t0, timeout_s=15.0)
    statuses = ctx.probe.statuses_since("planner", t0)
    used = {s.values.get("cloud_points_used") for s in statuses if s.values.get("cloud_points_in") == str(HUGE_POINTS)}
    ok = ok and all(u is not None and u.isdigit() and 0 < int(u) <= limit for u in used)
    seen_in = sorted({s.values.get("cloud_points_in", "-") for s in statuses})
    qos = sorted({s.values.get("cloud_qos", "-") for s in statuses})
    ctx.check(
        f"planner status reports {HUGE_POINTS} points in, at most {limit} used",
        ok,
        f"points in seen: {seen_in}, used with {HUGE_POINTS} in: {sorted(used)}, cloud subscription: {qos}",
    )
    if ctx.backend == "learned":
        ctx.check(
            "scene_encoder downsamples it", ctx.seen(f"downsampled from {HUGE_POINTS}", t0, ("scene_encoder",), 15)
        )
    time.sleep(max(0.0, t0 + 3.0 - time.monotonic()))
    ctx.probe.set_cloud(ctx.scene, rate_hz=10.0)
    ctx.resumes()


def camera_silent(ctx: Ctx) -> None:
    ctx.moving()  # the arm is on its way when the camera stops
    t0 = time.monotonic()
    ctx.probe.set_cloud(None)
    ctx.holds_after(t0, "holding: scene", STALE_SCENE_S + 2.0)
    if ctx.backend == "learned":
        ctx.check("scene_encoder reports stale input", ctx.seen("stale: no cloud", t0, ("scene_encoder",), 4.0))
    ctx.probe.set_cloud(ctx.scene)
    ctx.resumes("operation resumes when the camera is back")


def _goal_case(name: str) -> Callable[[Ctx], None]:
    def run(ctx: Ctx) -> None:
        bad, text = bad_goals(goal_pose("A"))[name]
        t0 = time.monotonic()
        ctx.probe.set_goal(bad)  # the goal source keeps sending it
        ctx.check("refusal reason on status/logs", ctx.seen(text, t0, ("planner",)))
        time.sleep(0.5)
        state = ctx.state()
        ok = state in ("tracking", "reached") and ctx.command_rate() >= 0.7 / PERIOD_S
        ctx.check("the planner keeps its previous goal", ok, f"state {state!r}")
        ctx.resumes("a valid goal is reached")

    return run


def goal_inside_unobserved_interior(ctx: Ctx) -> None:
    """A camera sees a box's surface only: a goal at its centre is 6 cm from the nearest observed point, so it is
    not refused as inside (and the probe's camera publishes no pose, so the hidden-goal rule, closed_loop.py
    goal_hidden_m, cannot look along its rays); the planner must not push into the box and must give up with a
    reason (the no-progress watchdog, shortened to GIVE_UP_S for this case)."""
    ok, reason = ctx.probe.set_parameter("planner", "closed_loop.no_progress_s", GIVE_UP_S)
    ctx.check(f"planner accepts closed_loop.no_progress_s={GIVE_UP_S}", ok, reason)
    ctx.probe.set_cloud(box_cloud(surface=True))
    time.sleep(3 * PERIOD_S)
    t0 = time.monotonic()
    o = goal_pose("A").pose.orientation
    ctx.probe.set_goal(pose_at(BOX_CENTRE, (o.x, o.y, o.z, o.w)))
    seen = ctx.seen("goal not reached: no progress", t0, ("planner",), 4 * GIVE_UP_S + 5.0)
    ctx.check("planner gives up with 'no progress'", seen, f"after {time.monotonic() - t0:.1f} s")
    ctx.probe.set_cloud(ctx.scene)
    ok, reason = ctx.probe.set_parameter("planner", "closed_loop.no_progress_s", ClosedLoopConfig().no_progress_s)
    ctx.check("planner accepts the default no_progress_s back", ok, reason)
    ctx.resumes("a valid goal is reached")


def _joint_case(name: str) -> Callable[[Ctx], None]:
    fault, text = JOINT_STATE_FAULTS[name]

    def run(ctx: Ctx) -> None:
        ctx.moving()
        t0, ros_t0 = time.monotonic(), ctx.probe.ros_now()
        ctx.probe.set_joint_fault(fault)
        if text:
            ctx.check("refusal reason on status/logs", ctx.seen(text, t0, ("planner",)))
            _commands_stop(ctx, t0, ros_t0)
        else:  # legal: the planner must keep working on it (the invariant catches a misread order)
            ctx.check("reaches a goal on these joint states", ctx.operating())
        ctx.probe.set_joint_fault(None)
        ctx.resumes()

    return run


def _commands_stop(ctx: Ctx, t0: float, ros_t0: float) -> None:
    """After joint states stop (or are refused) at t0 (monotonic; ros_t0 on the ROS clock), commands must stop
    within the staleness limit (judged by the commands' stamps: delays in delivery do not count)."""
    seen = ctx.seen("no command: joint states", t0, ("planner",), STALE_JOINTS_S + 2.0)
    ctx.check("planner reports 'no command: joint states'", seen)
    time.sleep(0.5)
    last = ctx.last_command_stamp()
    late = 0.0 if last is None else last - ros_t0
    ok = late <= STALE_JOINTS_S + 2 * PERIOD_S + 0.1
    ctx.check("commands stop", ok, f"last command stamped {late:.2f} s after the joint states stopped")


def joint_states_silent(ctx: Ctx) -> None:
    ctx.moving()
    t0, ros_t0 = time.monotonic(), ctx.probe.ros_now()
    ctx.probe.set_joint_fault(lambda q: None)
    _commands_stop(ctx, t0, ros_t0)
    ctx.probe.set_joint_fault(None)
    ctx.resumes("commands resume with the joint states")


PLANNER_BAD_PARAMS = (
    ("closed_loop.rate_hz", -1.0, "rate_hz must be a positive finite number"),
    ("closed_loop.rate_hz", "fast", "closed_loop.rate_hz: expected double, got string 'fast'"),
    ("closed_loop.max_iterations_per_tick", 0, "closed_loop.max_iterations_per_tick out of range"),
    ("amp_ls.lr", float("nan"), "lr must be a positive finite number"),
    ("amp_ls.collision_backend", "bogus", "collision_backend must be one of"),
    ("status_rate_hz", 0.0, "status_rate_hz out of range"),
    ("vae_checkpoint", "/nonexistent/vae", "checkpoint file missing"),
)
ENCODER_BAD_PARAMS = (
    ("max_points", -1, "max_points out of range"),
    ("downsample_voxel", 5.0, "downsample_voxel out of range"),
    ("checkpoint", "/nonexistent/collision", "checkpoint file missing"),
)


def _refused(ctx: Ctx, node: str, params) -> None:
    for name, value, text in params:
        ok, reason = ctx.probe.set_parameter(node, name, value)
        ctx.check(f"{node} refuses {name}={value!r} with a reason", not ok and text in reason, reason)


def bad_parameters(ctx: Ctx) -> None:
    """Bad values are refused with a reason; valid changes take effect (the control rate re-times the loop)."""
    _refused(ctx, "planner", PLANNER_BAD_PARAMS)
    ok, reason = ctx.probe.set_parameter("planner", "use_sim_time", ctx.suite.plan.with_sim)
    ctx.check("planner accepts use_sim_time (a ROS parameter)", ok, reason)
    ok, reason = ctx.probe.set_parameter("planner", "closed_loop.rate_hz", 20.0)
    ctx.check("planner accepts closed_loop.rate_hz=20", ok, reason)
    time.sleep(1.5)
    ctx.operating(timeout_s=5.0)
    rate = ctx.command_rate(1.0)
    ctx.check("the control loop runs at the new rate", rate >= 13.0, f"{rate:.0f} commands/s")
    ok, reason = ctx.probe.set_parameter("planner", "closed_loop.rate_hz", 1.0 / PERIOD_S)
    ctx.check("planner accepts the rate back", ok, reason)
    time.sleep(1.0)
    rate = ctx.command_rate(1.0)
    ctx.check("back at 10 Hz", 7.0 <= rate <= 13.0, f"{rate:.0f} commands/s")
    ctx.resumes()


def encoder_bad_parameters(ctx: Ctx) -> None:
    _refused(ctx, "scene_encoder", ENCODER_BAD_PARAMS)
    ctx.resumes()


def kill_planner(ctx: Ctx) -> None:
    ctx.moving()
    t0, ros_t0 = time.monotonic(), ctx.probe.ros_now()
    ctx.suite.kill("planner")
    time.sleep(2.0)
    after = [c for c in ctx.probe.commands_since(t0) if c[2] > ros_t0 + 0.05]  # stamped after the kill
    ctx.check("no commands from a dead planner", not after)
    if not ctx.suite.plan.with_sim:
        motion = ctx.arm_motion(t0 + 1.3)
        ctx.check("the arm holds without commands", motion < HELD_RAD, f"moved {motion:.4f} rad")
    t1 = time.monotonic()
    took = ctx.suite.restart("planner")
    ctx.note(f"planner restarted in {took:.1f} s")
    ready = ctx.seen("AMP-LS ready", t1, ("planner",), 5.0) or any(
        "AMP-LS ready" in x for x in ctx.suite.tail("planner")
    )
    ctx.check("the new planner logs that it is ready", ready)
    ctx.resumes("commands resume after the restart")


def kill_scene_encoder(ctx: Ctx) -> None:
    ctx.moving()
    t0 = time.monotonic()
    ctx.suite.kill("scene_encoder")
    ctx.holds_after(t0, "holding: scene", STALE_SCENE_S + 2.0)
    took = ctx.suite.restart("scene_encoder")
    ctx.note(f"scene_encoder restarted in {took:.1f} s")
    ctx.resumes("operation resumes with the restarted scene_encoder")


def _tick_stats(ctx: Ctx, t0: float, t1: float) -> dict:
    ticks, states = [], []
    for s in ctx.probe.statuses_since("planner", t0):
        if s.t > t1:
            break
        states.append(s.values.get("state", ""))
        try:
            ticks.append(float(s.values["tick_ms"]))
        except (KeyError, ValueError):
            pass
    cmds = [c[0] for c in ctx.probe.commands_since(t0) if c[0] <= t1]
    gaps = np.diff(cmds) if len(cmds) > 1 else np.zeros(0)
    return {
        "tick_ms_p50": percentile(ticks, 50),
        "tick_ms_p99": percentile(ticks, 99),
        "tick_ms_max": float(max(ticks)) if ticks else None,
        "ticks_reported": len(ticks),
        "commands_per_s": round(len(cmds) / (t1 - t0), 2),
        "command_gap_max_s": round(float(gaps.max()), 3) if gaps.size else None,
        "missed_periods": int(np.sum(np.maximum(np.round(gaps / PERIOD_S) - 1, 0))) if gaps.size else 0,
        "holding_share": round(sum(s == "holding" for s in states) / len(states), 3) if states else None,
        "tick_ms": ticks,
    }


def load(ctx: Ctx) -> None:
    """The planner's tick timing with the normal camera, then while 100k-point clouds arrive at 30 Hz."""
    t0 = time.monotonic()
    ctx.next_goal()
    time.sleep(LOAD_S / 2)
    baseline = _tick_stats(ctx, t0, time.monotonic())
    cloud = random_cloud(LOAD_POINTS)
    t1 = time.monotonic()
    ctx.probe.set_cloud(cloud, rate_hz=LOAD_RATE_HZ)
    seen = ctx.value_seen("cloud_points_in", lambda v: v == str(LOAD_POINTS), t1, timeout_s=LOAD_S / 2)
    ctx.check("planner receives the 100k-point clouds", seen)
    ctx.next_goal()  # keep the arm busy under load
    time.sleep(max(0.0, t1 + LOAD_S / 2 - time.monotonic()))
    ctx.next_goal()
    time.sleep(LOAD_S / 2)
    t2 = time.monotonic()
    loaded = _tick_stats(ctx, t1 + 1.0, t2)
    loaded["clouds_published_per_s"] = round(ctx.probe.clouds_published_since(t1 + 1.0) / (t2 - t1 - 1.0), 1)
    ctx.probe.set_cloud(ctx.scene, rate_hz=10.0)
    ctx.figures["load"] = {
        "cloud_points": LOAD_POINTS,
        "cloud_rate_hz": LOAD_RATE_HZ,
        "duration_s": LOAD_S,
        "backend": ctx.backend,
        "baseline": baseline,
        "loaded": loaded,
    }
    ctx.note(
        f"tick p50/p99 {baseline['tick_ms_p50']}/{baseline['tick_ms_p99']} ms at rest, "
        f"{loaded['tick_ms_p50']}/{loaded['tick_ms_p99']} ms under load; "
        f"{loaded['commands_per_s']} commands/s, {loaded['missed_periods']} missed periods under load"
    )
    # the figures are measurements (they depend on the machine's load); surviving means not being starved
    ctx.check("commands continue under load", loaded["commands_per_s"] >= 1.0, f"{loaded['commands_per_s']}/s")
    ctx.resumes()


def sim_reset(ctx: Ctx) -> None:
    """sim/reset while the arm moves: the arm jumps back to the start; commands must follow the new state."""
    ctx.next_goal()
    t_goal = time.monotonic()
    q_start = ctx.probe.arm_q()
    moving = ctx.wait(lambda: np.max(np.abs(ctx.probe.arm_q() - q_start)) > 0.1, 10.0)
    ctx.check("the arm is in motion", moving, f"{time.monotonic() - t_goal:.1f} s after the goal")
    t0 = time.monotonic()
    message = ctx.probe.reset_sim()
    ctx.note(f"sim/reset: {message}")
    ctx.check("the sim logs the reset", ctx.seen("scenario 'empty'", t0, ("sim",), 3.0))
    ctx.check("the planner tracks from the reset state", ctx.operating(new_goal=False))
    ctx.resumes()


# ---------------------------------------------------------------------------------------------- groups
Case = tuple[str, Callable[[Ctx], None]]


def group_cases(group: str, backend: str) -> list[Case]:
    """The cases of a group for the suite's backend, in run order."""
    if group == "inputs":
        goals = [(n, _goal_case(n)) for n in bad_goals(goal_pose("A"))]
        joints = [(n, _joint_case(n)) for n in JOINT_STATE_FAULTS]
        goals.append(("goal_inside_unobserved_interior", goal_inside_unobserved_interior))
        return [*goals, *joints, ("joint_states_silent", joint_states_silent), ("bad_parameters", bad_parameters)]
    if group == "scene":
        clouds = [(n, _cloud_case(n)) for n in malformed_clouds(box_cloud())]
        # the load figure first, on a fresh suite; the kills last
        cases = [("load_30hz_100k", load), *clouds, ("cloud_2m_points", huge_cloud), ("camera_silent", camera_silent)]
        if backend == "learned":
            cases += [("encoder_bad_parameters", encoder_bad_parameters), ("kill_scene_encoder", kill_scene_encoder)]
        return [*cases, ("kill_planner", kill_planner)]
    if group == "sim":
        return [("sim_reset_mid_motion", sim_reset)]
    raise ValueError(f"unknown group {group!r}")


GROUPS = {
    "inputs": {"backend": "geometric", "with_sim": False},
    "scene": {"backend": "configured", "with_sim": False},
    "sim": {"backend": "configured", "with_sim": True},
    "startup": {},
}
"""Group name -> how its suite runs (see the module docstring)."""


@dataclass
class GroupInfo:
    """How a group ran: backend, nodes, notes, start-up time [s], wall time [s], figures (the load case's)."""

    name: str
    backend: str = ""
    nodes: tuple[str, ...] = ()
    notes: tuple[str, ...] = ()
    startup_s: float = 0.0
    wall_s: float = 0.0
    exit_codes: dict = field(default_factory=dict)
    figures: dict = field(default_factory=dict)


def run_case(ctx: Ctx, name: str, fn: Callable[[Ctx], None]) -> CaseResult:
    """Run one case and add the checks every case has: no crash, the invariant held."""
    result = ctx.result = CaseResult(name, ctx.group)
    t0 = time.monotonic()
    try:
        fn(ctx)
    except Exception as err:  # a case that cannot finish is a failed case, not a failed run
        ctx.check("case ran to the end", False, f"{type(err).__name__}: {err}")
    crashed = ctx.suite.crashed()
    ctx.check("no crash", not crashed, ", ".join(f"{n} {how}" for n, how in crashed.items()))
    for node in crashed:  # keep the group going
        try:
            ctx.suite.restart(node)
        except Exception as err:
            ctx.note(f"could not restart {node}: {err}")
    found = ctx.probe.violations_since(t0)
    result.violations = len(found)
    ctx.check("safety invariant", not found, "; ".join(f"{v.kind}: {v.detail}" for v in found[:3]))
    result.duration_s = time.monotonic() - t0
    result.survived = all(result.checks.values())
    ctx.probe.trim(60.0)
    return result


def run_group(
    group: str,
    log_path: str | Path | None = None,
    domain_id: int | None = None,
    collision_checkpoint: str = "",
    only: list[str] | None = None,
    progress: Callable[[CaseResult], None] | None = None,
) -> tuple[list[CaseResult], GroupInfo]:
    """Start the group's suite once, run its cases (all, or those named in `only`), stop it.

    Raises StartupError when the suite does not come up.
    """
    t_start = time.monotonic()
    info = GroupInfo(group)
    if group == "startup":
        results = run_startup_group(domain_id)
        info.wall_s = time.monotonic() - t_start
        for r in results:
            if progress is not None:
                progress(r)
        return results, info
    spec = GROUPS[group]
    plan = plan_fault_suite(spec["backend"], spec["with_sim"], collision_checkpoint)
    info.backend, info.nodes, info.notes = plan.backend, plan.nodes, plan.notes
    results = []
    with FaultSuite(plan, log_path=log_path, domain_id=domain_id) as suite:
        info.startup_s = suite.start()
        ctx = Ctx(suite, group)
        ctx.probe.set_cloud(ctx.scene, rate_hz=10.0)
        if not ctx.operating(timeout_s=60.0):
            raise StartupError("planner", f"the {group} suite does not reach a first goal within 60 s")
        for name, fn in group_cases(group, plan.backend):
            if only is not None and name not in only:
                continue
            r = run_case(ctx, name, fn)
            results.append(r)
            if progress is not None:
                progress(r)
        info.figures = ctx.figures
        info.exit_codes = suite.stop()
    info.wall_s = time.monotonic() - t_start
    return results, info


def summarise(results: list[CaseResult]) -> dict:
    """The headline figures of a set of cases."""
    return {
        "cases": len(results),
        "survived": sum(r.survived for r in results),
        "failed": [r.name for r in results if not r.survived],
        "invariant_violations": sum(r.violations for r in results),
    }


def main_print(r: CaseResult) -> None:
    """A one-line progress report on stderr."""
    state = "survived" if r.survived else "FAILED " + ", ".join(r.failures())
    print(f"[faults] {r.group}/{r.name}: {state} ({r.duration_s:.1f} s)", file=sys.stderr, flush=True)

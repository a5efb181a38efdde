"""`bench soak`: the closed-loop suite through the ROS graph for N minutes on a randomised, seeded workload.

    python -m latent_planner_ros bench soak --out DIR [--minutes N] [--seed S] [--backend geometric|learned]
        [--real-time-factor F] [--domain-id N] [--planner-set NAME=VALUE ...]

The suite is the conveyor bench's (sim, scene_encoder for the learned backend, planner, each with its
``config/<node>.yaml`` and ``use_sim_time``), with the planner's ``joint_states`` and the planner's and encoder's
``camera/points`` remapped onto the relays of the soak probe (evaluation/probes/soak_probe.py), which can pause
them. The workload (evaluation/soak_workload.py, seeded by ``--seed``) alternates the tabletop and conveyor scenarios
(moving target and obstacle), sends goals every 2-10 s (reachable, unreachable, inside obstacles, the conveyor's
moving target, grasp goals), drops the camera out for 0.5-3 s, pauses joint states, changes planner parameters
(valid values and refused ones) and requests one-shot plans while the loop tracks. The safety monitor checks every
``joint_command`` against the sim's joint states. Every few seconds each node's RSS, open fds and threads are
read from /proc (soak_procfs.py).

Writes ``DIR/soak.json`` (``minutes``, ``invariant_violations``, ``contacts``, ``node_crashes``,
``rss_growth_pct_per_hour_max`` (the worst node), ``tick_ms_p99_max_minute`` (the worst minute),
``goals_without_outcome`` (goals neither reached, refused nor given up before the next one), and the rest of
evaluation/soak_report.py's summary), ``DIR/soak.md``, plots ``DIR/soak_{resources,ticks,goals}.png``, the
workload ``DIR/soak_events.json`` and the nodes' output ``DIR/soak_nodes.log``. Minutes are simulated time.
Exit code 0 when the run finished without violations, contacts or crashes, 1 otherwise. SIGINT (Ctrl-C) or
SIGTERM ends the run early and writes the report of the minutes run.
"""

from __future__ import annotations

import json
import random
import signal
import sys
import threading
import time
from dataclasses import replace
from pathlib import Path

from latent_planner_ros.bench.conveyor import add_planner_set, check_planner_set
from latent_planner_ros.bench.report import bench_parser, write_report
from latent_planner_ros.evaluation.soak_report import SoakLog

RESOURCE_PERIOD_S = 10.0
"""[s] wall time between two /proc samples of every node (shorter for short runs)."""
STALL_TIMEOUT_S = 30.0
"""[s] of wall time without simulated time advancing after which the sim counts as stalled."""
JOINT_PAUSE_EXCUSE_S = 0.3
"""[s] after a joint-state pause ends, the planner may still be without fresh states (the next state's transit)."""


def plan_soak(backend: str | None, seed: int, real_time_factor: float, planner_set: list[str] | None = None):
    """The conveyor bench's SuitePlan turned into the soak's: tabletop first, the planner disabled until the first
    scene is up, its joint states and clouds (and the encoder's) from the probe's relays, goals from the probe."""
    from latent_planner_ros.evaluation.conveyor_suite import plan_suite
    from latent_planner_ros.evaluation.probes.soak_probe import CLOUD_RELAY, JOINTS_RELAY

    plan = plan_suite(
        backend, seed=seed, real_time_factor=real_time_factor, status_rate_hz=10.0, planner_set=planner_set or ()
    )
    params = {n: list(v) for n, v in plan.params.items()}
    params["sim"] = [p for p in params["sim"] if not p.startswith("scenario:=")] + ["scenario:=tabletop"]
    cloud = ["-r", f"camera/points:={CLOUD_RELAY}"]
    ros_args = {"planner": ["-r", f"joint_states:={JOINTS_RELAY}", *cloud], "scene_encoder": cloud}
    return replace(plan, params=params, ros_args=ros_args)


class SoakRun:
    """Applies the workload's events to the suite through the probe; the state between events."""

    def __init__(self, session, log: SoakLog):
        self.s = session
        self.log = log
        self.scene = None
        self.scenario = ""
        self.camera_off_until = -1.0
        self.joints_off_until = -1.0
        self.applied: dict[str, int] = {}
        self.skipped: list[str] = []
        self.errors: list[str] = []

    def apply(self, ev, now: float) -> None:
        from latent_planner_ros.evaluation.soak_workload import resolve_pose
        from sim_bridge.scenario_files import load_scenario, parse_overrides

        p = ev.params
        if ev.kind == "scenario":
            self.s.switch_scenario(p["scenario"], p["seed"], p["overrides"])
            self.scene = load_scenario(p["scenario"], seed=p["seed"], overrides=parse_overrides(p["overrides"]))
            self.scenario = p["scenario"]
        elif ev.kind in ("goal", "grasp_goal"):
            kind = p.get("goal", "grasp")
            if kind == "conveyor_target":
                if self.scenario != "conveyor":
                    return self._skip(ev, "no moving target in this scenario")
                self.s.send_goal(kind, None)
            else:
                pose = resolve_pose(ev, self.scene)
                if pose is None:
                    return self._skip(ev, "no object in this scene the open hand fits round")
                self.s.send_goal(kind, pose, grasp=ev.kind == "grasp_goal")
        elif ev.kind == "camera_dropout":
            self.camera_off_until = max(self.camera_off_until, now + p["duration_s"])
            self.s.set_relays(camera=False)
        elif ev.kind == "joint_pause":
            self.joints_off_until = max(self.joints_off_until, now + p["duration_s"])
            self.s.set_relays(joints=False)
            self.log.excused.append((now, self.joints_off_until + JOINT_PAUSE_EXCUSE_S))
        elif ev.kind == "param_change":
            ok, reason = self.s.set_parameter("planner", p["name"], p["value"])
            self.log.params.append({"t": round(now, 2), **p, "successful": ok, "reason": reason})
        elif ev.kind == "plan_request":
            pose = resolve_pose(ev, self.scene)
            self.s.request_plan(pose, p["tolerance"], "refused" if p["tolerance"] < 0 else "plan")
        self.applied[ev.kind] = self.applied.get(ev.kind, 0) + 1

    def _skip(self, ev, why: str) -> None:
        self.skipped.append(f"{ev.kind} at {ev.t:.1f} s: {why}")

    def end_pauses(self, now: float) -> None:
        if self.camera_off_until >= 0 and now >= self.camera_off_until:
            self.camera_off_until = -1.0
            self.s.set_relays(camera=True)
        if self.joints_off_until >= 0 and now >= self.joints_off_until:
            self.joints_off_until = -1.0
            self.s.set_relays(joints=True)


def _sample_resources(supervisor, t: float) -> list[tuple]:
    from latent_planner_ros.evaluation.soak_procfs import group_usage

    rows = []
    for name, pid in supervisor.pids.items():
        u = group_usage(pid)
        if u is not None:
            rows.append((t, name, round(u.rss_mb, 2), u.fds, u.threads))
    return rows


def run_soak(args, out: Path, stop: threading.Event | None = None) -> tuple[SoakLog, dict]:
    """Start the suite, run the workload for args.minutes of simulated time (or until `stop` is set), stop the
    suite; (the log, run info)."""
    from latent_planner_ros.evaluation.probes.graph_probe import GraphProbe
    from latent_planner_ros.evaluation.probes.soak_probe import SoakSession
    from latent_planner_ros.evaluation.soak_workload import counts, generate
    from latent_planner_ros.processes.node_suite import suite_env, suite_specs
    from latent_planner_ros.processes.supervisor import Supervisor, describe_exit

    plan = plan_soak(args.backend, args.seed, args.real_time_factor, args.planner_set)
    for note in plan.notes:
        print(f"[bench soak] {note}", file=sys.stderr)
    events = generate(args.minutes, args.seed)
    (out / "soak_events.json").write_text(json.dumps([e.to_dict() for e in events], indent=1) + "\n")
    total = 60.0 * args.minutes
    resource_period = min(RESOURCE_PERIOD_S, max(1.0, total / 20.0))
    log_file = open(out / "soak_nodes.log", "w", buffering=1)  # noqa: SIM115 (closed below)
    env = suite_env(args.domain_id, headless=True)
    specs = suite_specs(plan.nodes, plan.params, env, ros_args=plan.ros_args)
    supervisor = Supervisor(specs, stdout=log_file, stderr=log_file, label="soak")
    session = None
    info = {"backend": plan.backend, "nodes_run": list(plan.nodes), "notes": list(plan.notes), "seed": args.seed}
    try:
        t_start = time.monotonic()
        session = SoakSession(args.domain_id)  # first, so it hears every node's /rosout from the start
        supervisor.start()
        with GraphProbe(domain_id=args.domain_id) as probe:
            if not supervisor.wait_ready(probe.ready_nodes, 180.0, stop):
                raise RuntimeError("stopped during start-up")
        session.wait_clock()
        info["startup_s"] = round(time.monotonic() - t_start, 1)
        print(f"[bench soak] {', '.join(plan.nodes)} up after {info['startup_s']:.0f} s", file=sys.stderr)
        session.start(args.minutes)
        log = session.node.record
        run = SoakRun(session, log)
        i, next_sample, next_print = 0, 0.0, time.monotonic() + 30.0
        last_clock, last_change = None, time.monotonic()
        enabled = False
        while True:
            now = session.now()
            if now >= total or (stop is not None and stop.is_set()):
                break
            wall = time.monotonic()
            crashed = supervisor.exited()
            if crashed:
                for name, code in crashed.items():
                    log.crashes.append(
                        {
                            "node": name,
                            "t": round(now, 1),
                            "how": describe_exit(code),
                            "tail": supervisor.tail(name)[-15:],
                        }
                    )
                print(f"[bench soak] node crash: {log.crashes}", file=sys.stderr)
                break
            clock = session.clock()
            if clock != last_clock:
                last_clock, last_change = clock, wall
            elif wall - last_change > STALL_TIMEOUT_S:
                log.crashes.append({"node": "sim", "t": round(now, 1), "how": "simulated time stopped", "tail": []})
                break
            while i < len(events) and events[i].t <= now:
                try:
                    run.apply(events[i], now)
                except (RuntimeError, TimeoutError) as err:  # a refused reset, a service that did not answer
                    run.errors.append(f"{events[i].kind} at {now:.1f} s: {err}")
                i += 1
                if not enabled:  # after the first scene is up
                    session.enable_planner(True)
                    enabled = True
            run.end_pauses(now)
            if wall >= next_sample:
                rows = _sample_resources(supervisor, now)
                session.with_record(lambda r, rows=rows: r.resources.extend(rows))
                next_sample = wall + resource_period
            if wall >= next_print:
                next_print = wall + 30.0
                print(
                    f"[bench soak] {now / 60:.1f}/{args.minutes:g} min: {len(log.goals)} goals, "
                    f"{len(log.violations)} violations, {len(log.contacts)} contacts",
                    file=sys.stderr,
                    flush=True,
                )
            time.sleep(0.02)
        run.end_pauses(float("inf"))
        end = time.monotonic() + 8.0
        while time.monotonic() < end and any(not p.get("answered") and "reason" not in p for p in log.plans):
            time.sleep(0.2)  # outstanding one-shot plans
        time.sleep(0.5)
        session.settle_plans()
        with session.node.lock:
            log.duration_s = min(max(session.node._t() or 0.0, 0.0), max(total, 0.0))
            log.events = {**counts(events[:i]), "skipped": len(run.skipped)}
            log.safety = session.node.safety.summary()
            for p in log.plans:
                p.pop("_key", None)
        info["skipped"] = run.skipped
        info["event_errors"] = run.errors
        info["wall_s"] = round(time.monotonic() - t_start, 1)
        info["relayed"] = dict(session.node.relayed)
        return log, info
    finally:
        if session is not None:
            session.close()
        codes = supervisor.stop()
        info["exit_codes"] = codes
        log_file.close()


def main(argv: list[str]) -> int:
    p = bench_parser("soak", __doc__.split("\n\n")[0])
    p.add_argument("--minutes", type=float, default=30.0, help="simulated minutes (default 30)")
    p.add_argument("--seed", type=int, default=0, help="seed of the workload (default 0)")
    p.add_argument("--backend", choices=("geometric", "learned"), help="default: config/planner.yaml's")
    p.add_argument("--real-time-factor", type=float, default=1.0, metavar="F", help="sim pace (default 1)")
    p.add_argument("--domain-id", type=int, metavar="N", help="ROS_DOMAIN_ID (default: a random one)")
    add_planner_set(p)
    args = p.parse_args(argv)
    check_planner_set(p, args.planner_set)
    if not 0 < args.minutes <= 24 * 60 or not 0.1 <= args.real_time_factor <= 10:
        p.error("--minutes in (0, 1440] and --real-time-factor in [0.1, 10] are required")
    if args.domain_id is None:
        args.domain_id = random.SystemRandom().randint(1, 101)

    from latent_planner_ros.evaluation.soak_report import figures, markdown, summarise
    from latent_planner_ros.processes.node_suite import SuiteError
    from latent_planner_ros.processes.supervisor import StartupError

    args.out.mkdir(parents=True, exist_ok=True)
    stop = threading.Event()

    def request_stop(signum, frame) -> None:
        print(
            f"[bench soak] {signal.Signals(signum).name}: stopping, the report covers the minutes run", file=sys.stderr
        )
        stop.set()

    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, request_stop)
    try:
        log, info = run_soak(args, args.out, stop)
    except (SuiteError, StartupError, RuntimeError, TimeoutError) as err:
        print(f"[bench soak] error: {err} (node output: {args.out / 'soak_nodes.log'})", file=sys.stderr)
        return 1
    res = summarise(log)
    res.update(info)
    write_report(args.out, "soak", res, markdown(res), figures(log, res), argv)
    print(
        f"[bench soak] {res['minutes']:.1f} min: {res['invariant_violations']} violations, {res['contacts']} contacts, "
        f"{res['node_crashes']} crashes, worst RSS growth {res['rss_growth_pct_per_hour_max']} %/h, worst minute's "
        f"tick p99 {res['tick_ms_p99_max_minute']} ms, goals {res['goals']['sent']} (reached {res['goals']['reached']},"
        f" refused {res['goals']['refused']}, failed {res['goals']['failed']}, timed out {res['goals']['timed_out']})",
        file=sys.stderr,
    )
    ok = res["invariant_violations"] == 0 and res["contacts"] == 0 and res["node_crashes"] == 0
    return 0 if ok else 1

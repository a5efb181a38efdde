"""The README's main job (``make demo``): the arm tracks a moving target on a conveyor, through the ROS graph.

    python -m latent_planner_ros demo [--duration S] [--out DIR] [--seed N] [--backend geometric|learned]
        [--no-record] [--view [--view-port N]]

Starts the node suite as processes (``sim`` with the conveyor scenario, ``planner`` chasing the sim's
``target_pose``, and ``scene_encoder`` when the planner's collision backend is the learned one), resets the
scene, enables the planner and watches ``--duration`` seconds of simulated time with a live status line.
Then it stops the suite and prints a summary: reached and tracked (end effector within 3 cm and 20 deg of the
moving target, then staying there), time to reach, share of time tracking, the arm's minimum distance to the
scene objects (ground truth from the sim), contacts, and the planner's tick timings. ``--out`` receives
``summary.json``, ``tracking.png`` (end effector vs target x/y/z over time), ``scene.png`` (a strip of
pictures rendered from the logged joint states), ``trial.npz`` (the time series), ``nodes.log`` and ``bag/``: every
topic of the run as a rosbag2 MCAP bag (``--no-record``: none; ``python -m latent_planner_ros replay DIR/bag``).
``--view`` serves the live 3D view at http://localhost:8080 while the demo runs.

Exit code 0 when the run completed (whether or not the target was reached: the summary says), 1 when the
suite failed (a node died or did not come up), 130 when interrupted.
"""

from __future__ import annotations

import argparse
import json
import os
import signal
import sys
import time
from pathlib import Path

import numpy as np

DEFAULT_OUT = Path("demo_out")


def parse_args(argv: list[str]) -> argparse.Namespace:
    p = argparse.ArgumentParser(
        prog="latent-planner demo", description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    p.add_argument("--duration", type=float, default=30.0, metavar="S", help="simulated seconds (default 30)")
    p.add_argument("--out", type=Path, default=DEFAULT_OUT, help=f"output directory (default {DEFAULT_OUT}/)")
    p.add_argument("--seed", type=int, default=0, help="scenario seed: target and obstacle layout (default 0)")
    p.add_argument(
        "--backend",
        choices=("geometric", "learned"),
        help="the planner's collision backend (default: config/planner.yaml's)",
    )
    p.add_argument(
        "--real-time-factor", type=float, default=1.0, metavar="F", help="simulated s per wall s (default 1)"
    )
    p.add_argument("--domain-id", type=int, metavar="N", help="ROS_DOMAIN_ID (default: the environment's)")
    p.add_argument("--frames", type=int, default=6, help="pictures in the scene strip (default 6; 0 = none)")
    p.add_argument("--no-record", action="store_true", help="do not record the run into OUT/bag")
    p.add_argument("--view", action="store_true", help="serve the live 3D view on localhost (see --view-port)")
    p.add_argument("--view-port", type=int, default=8080, metavar="N", help="the view's port (default 8080)")
    args = p.parse_args(argv)
    if not 0 < args.duration <= 3600:
        p.error("--duration must be in (0, 3600] s")
    if not 0.1 <= args.real_time_factor <= 10:
        p.error("--real-time-factor must be in [0.1, 10]")
    if args.domain_id is not None and not 0 <= args.domain_id <= 232:
        p.error("--domain-id must be in 0..232")
    return args


def say(text: str) -> None:
    print(f"[demo] {text}", flush=True)


class StatusLine:
    """The live one-line status: rewritten in place on a terminal, a line every 5 s of sim time otherwise."""

    def __init__(self, duration_s: float, stream=None):
        from latent_planner_ros.robot.panda import load_panda

        self.duration_s = duration_s
        self.stream = stream or sys.stdout
        self.tty = self.stream.isatty()
        self.panda = load_panda()
        self._next_line = 0.0
        self._width = 0

    def __call__(self, t: float, live) -> None:
        dist = "EE-target   n/a  "
        if live.q is not None and live.target_position is not None:
            err = np.linalg.norm(self.panda.fk(live.q).translation - live.target_position)
            dist = f"EE-target {100 * err:5.1f} cm"
        tick = f"{live.tick_ms:5.1f} ms" if np.isfinite(live.tick_ms) else "  n/a   "
        state = f"{live.state} ({live.source})" if live.source else live.state
        text = (
            f"[demo] t {t:5.1f}/{self.duration_s:g} s | {dist} | planner {state:<17} | tick {tick} | "
            f"contacts {live.contacts}"
        )
        if self.tty:
            self.stream.write("\r" + text.ljust(self._width))
            self._width = len(text)
            self.stream.flush()
        elif t >= self._next_line:
            self._next_line = t + 5.0
            print(text, file=self.stream, flush=True)

    def done(self) -> None:
        if self.tty and self._width:
            self.stream.write("\n")
            self.stream.flush()


def _raise_interrupt(signum, frame) -> None:
    raise KeyboardInterrupt


def run(args: argparse.Namespace) -> int:
    from latent_planner_ros.evaluation.conveyor_suite import ConveyorSuite, StartupError, SuiteFailed, plan_suite
    from latent_planner_ros.evaluation.trial import format_summary, plot_tracking, tracking, trial_metrics
    from latent_planner_ros.processes.node_suite import SuiteError

    out = args.out
    out.mkdir(parents=True, exist_ok=True)
    try:
        plan = plan_suite(args.backend, seed=args.seed, real_time_factor=args.real_time_factor)
    except SuiteError as err:
        print(f"[demo] error: {err}", file=sys.stderr)
        return 2
    domain = args.domain_id if args.domain_id is not None else os.environ.get("ROS_DOMAIN_ID", "0")
    say(f"conveyor scenario (seed {plan.seed}), {args.duration:g} s of simulated time; planner backend {plan.backend}")
    for note in plan.notes:
        say(note)
    log_path = out / "nodes.log"
    say(f"starting {', '.join(plan.nodes)} on ROS_DOMAIN_ID={domain} (node output: {log_path})")
    status = StatusLine(args.duration)
    suite = ConveyorSuite(plan, log_path=log_path, domain_id=args.domain_id)
    if args.view:
        from latent_planner_ros.processes.node_suite import suite_env
        from latent_planner_ros.view.process import view_spec

        suite.supervisor.specs.append(view_spec(args.view_port, suite_env(args.domain_id, headless=True)))
    recorder, bag_path = None, out / "bag"
    t_start = time.monotonic()
    try:
        up_s = suite.start()
        say(f"all nodes up after {up_s:.1f} s; resetting the scene and enabling the planner")
        if args.view:
            say(f"the view: http://localhost:{args.view_port}")
        if not args.no_record:
            from latent_planner_ros.nodes.bag_recorder import RecorderSession

            recorder = RecorderSession(bag_path, args.domain_id, overwrite=True)
        log = suite.run_trial(args.duration, progress=status)
        status.done()
        if recorder is not None:
            bag, recorder = recorder.close(), None
            size = sum(f.stat().st_size for f in bag_path.iterdir()) / 1e6
            say(f"bag {bag_path}: {bag.message_count} messages on {len(bag.topics)} topics, {size:.1f} MB")
    except (StartupError, SuiteFailed) as err:
        status.done()
        print(f"[demo] error: {err}", file=sys.stderr)
        if isinstance(err, SuiteFailed):
            tail = err.tail
        else:
            tail = suite.supervisor.tail(err.name) if err.name in suite.supervisor.pids else []
        for line in tail[-15:]:
            print(f"[{err.name}] {line}", file=sys.stderr)
        print(f"[demo] full node output: {log_path}", file=sys.stderr)
        return 1
    except (RuntimeError, TimeoutError) as err:
        status.done()
        print(f"[demo] error: {err} (node output: {log_path})", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        status.done()
        say("interrupted: stopping the suite")
        return 130
    finally:
        if recorder is not None:
            recorder.close()
        suite.stop()
    run_s = time.monotonic() - t_start

    track = tracking(log)
    metrics = trial_metrics(log, track=track)
    np.savez_compressed(out / "trial.npz", **{k: np.asarray(v) for k, v in vars(log).items()})
    pictures = {}
    fig = plot_tracking(track, metrics, title=f"conveyor, seed {plan.seed}: end effector vs moving target")
    fig.savefig(out / "tracking.png", dpi=110)
    pictures["tracking"] = str(out / "tracking.png")
    if args.frames > 0 and len(track.t):
        try:
            from latent_planner_ros.evaluation.pictures import render_strip
            from sim_bridge.scenario_files import load_scenario

            scenario = load_scenario("conveyor", seed=plan.seed)
            pictures["scene"] = str(render_strip(scenario, track, log.scenario_start_s, out / "scene.png", args.frames))
        except RuntimeError as err:  # no OpenGL: the summary still stands
            say(f"no scene pictures: {err}")
    summary = {
        "scenario": "conveyor",
        "seed": plan.seed,
        "backend": plan.backend,
        "configured_backend": plan.configured_backend,
        "nodes": list(plan.nodes),
        "real_time_factor": plan.real_time_factor,
        "wall_s": run_s,
        **metrics,
        "pictures": pictures,
        "bag": None if args.no_record else str(bag_path),
    }
    (out / "summary.json").write_text(json.dumps(summary, indent=2) + "\n")
    print()
    print(f"Summary ({args.duration:g} s of simulated time, {run_s:.0f} s wall, backend {plan.backend})")
    print(format_summary(metrics))
    print(f"pictures         {', '.join(pictures.values())}")
    print(f"all figures      {out / 'summary.json'}")
    return 0


def main(argv: list[str] | None = None) -> int:
    args = parse_args(sys.argv[1:] if argv is None else list(argv))
    previous = signal.signal(signal.SIGTERM, _raise_interrupt)  # stop the suite on SIGTERM too
    try:
        return run(args)
    finally:
        signal.signal(signal.SIGTERM, previous)

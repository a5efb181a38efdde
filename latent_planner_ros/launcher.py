"""``python -m latent_planner_ros launch``: start the node suite as processes, without ``ros2 launch``.

    python -m latent_planner_ros launch [--scenario NAME|FILE] [--with-ompl] [--execute NODE] [--headless]
        [--domain-id N] [--nodes a,b,c] [--duration S] [--param NODE:NAME:=VALUE ...] [--startup-timeout S]
        [--view [--view-port N]] [--record DIR]

Starts each node (default: sim, scene_encoder, planner) as ``python -m latent_planner_ros run <node>``
with its ``config/<node>.yaml`` and ``use_sim_time:=true``, all on one ROS_DOMAIN_ID, each in its own
process group; echoes their output prefixed with ``[node]``; waits until every node is up (in the ROS
graph with a publisher of its own, i.e. its start-up work is done); then runs until Ctrl-C / SIGTERM,
until ``--duration`` seconds have passed, or until a node exits, and stops the suite (SIGINT, then
SIGTERM, then SIGKILL; a second Ctrl-C skips the grace periods).

One command source at a time: the planners start disabled and ``--execute`` names the one that commands the arm
(``planner``: its closed loop is enabled; ``ompl_planner``: ``execute:=true``; ``none``; default ``planner`` when
it is in the suite); a ``--param`` that would enable the other one is refused. At run time, enabling one of them
disables the other (nodes/execution_owner.py).

``--headless``: the suite never opens a MuJoCo viewer and never records video (the sim's ``--record`` is for
``run sim``); the flag makes MuJoCo render offscreen with osmesa (unless MUJOCO_GL is set) so the
suite runs the same on a desktop as on a server.

``--view`` adds the live 3D view (``python -m latent_planner_ros view``, a process named ``view``) at
http://localhost:8080 (``--view-port``); ``--record DIR`` records every topic from start-up to the stop into a
rosbag2 MCAP bag in the new directory DIR (nodes/bag_recorder.py; ``ros2 bag info DIR``, ``... replay DIR``).

Exit codes: 0 after ``--duration`` or a requested stop; 1 when a node failed (died during start-up,
was not up in time, or exited while the suite ran; the message names it); 2 on bad arguments.
A ROS 2 install can use ``ros2 launch latent_planner_ros latent_planner.launch.py`` instead.
"""

from __future__ import annotations

import argparse
import os
import signal
import sys
import threading
from pathlib import Path

from latent_planner_ros.processes.node_suite import DEFAULT_NODES, SuiteError, parse_param, suite_env, suite_specs
from latent_planner_ros.processes.supervisor import StartupError, Supervisor, describe_exit
from latent_planner_ros.registry import NODES

DEFAULT_SCENARIO = "conveyor"
STARTUP_TIMEOUT_S = 90.0
"""Default longest wait [s] for every node to be up (the planner loads torch models)."""


def parse_args(argv: list[str]) -> argparse.Namespace:
    parser = argparse.ArgumentParser(
        prog="latent-planner launch", description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument(
        "--scenario",
        default=DEFAULT_SCENARIO,
        metavar="NAME|FILE",
        help=f"the sim's scenario: a name in config/scenarios or a YAML file (default {DEFAULT_SCENARIO})",
    )
    parser.add_argument("--with-ompl", action="store_true", help="also start the ompl_planner baseline node")
    parser.add_argument(
        "--execute",
        choices=EXECUTION_SOURCES + ("none",),
        help="the node that commands the arm (default: planner when it is in the suite, else none)",
    )
    parser.add_argument("--headless", action="store_true", help="no viewer or recording; render offscreen (osmesa)")
    parser.add_argument("--domain-id", type=int, metavar="N", help="ROS_DOMAIN_ID of all nodes (default: inherited)")
    parser.add_argument(
        "--nodes",
        default=",".join(DEFAULT_NODES),
        metavar="a,b,c",
        help=f"comma-separated nodes to start, in order (default {','.join(DEFAULT_NODES)}; "
        f"available: {','.join(sorted(NODES))})",
    )
    parser.add_argument(
        "--duration", type=float, metavar="S", help="stop the suite S seconds after every node is up (exit 0)"
    )
    parser.add_argument(
        "--param",
        action="append",
        default=[],
        metavar="NODE:NAME:=VALUE",
        help="a parameter for one node, after its params file (repeatable), e.g. sim:real_time_factor:=0",
    )
    parser.add_argument(
        "--view", action="store_true", help="also serve the live 3D view on localhost (see --view-port)"
    )
    parser.add_argument("--view-port", type=int, default=8080, metavar="N", help="the view's port (default 8080)")
    parser.add_argument(
        "--record", type=Path, metavar="DIR", help="record every topic into a rosbag2 MCAP bag in DIR (a new directory)"
    )
    parser.add_argument(
        "--startup-timeout",
        type=float,
        default=STARTUP_TIMEOUT_S,
        metavar="S",
        help=f"longest wait for every node to be up (default {STARTUP_TIMEOUT_S:g} s)",
    )
    args = parser.parse_args(argv)
    if args.domain_id is not None and not 0 <= args.domain_id <= 232:
        parser.error(f"--domain-id: expected 0..232, got {args.domain_id}")
    if args.duration is not None and args.duration < 0:
        parser.error("--duration must not be negative")
    if args.startup_timeout <= 0:
        parser.error("--startup-timeout must be positive")
    return args


EXECUTION_SOURCES = ("planner", "ompl_planner")
"""nodes that command the arm on joint_trajectory, one at a time"""
ENABLING = {"planner": "enabled", "ompl_planner": "execute"}
"""the boolean parameter that makes each execution source command the arm"""

CLOUD_CONSUMERS = ("scene_encoder", "planner", "ompl_planner")
"""nodes that subscribe to the sim's clouds (`cloud_topics`)"""


def scenario_cloud_topics(scenario: str) -> list[str]:
    """The cloud topics of the sim's cameras for a scenario: `camera/points` and `<name>/points` for each camera
    the scenario file brings (sim_bridge/camera_rig.py). Raises SuiteError for a scenario that does not load."""
    from sim_bridge.scenario import ScenarioError
    from sim_bridge.scenario_files import load_scenario

    try:
        cameras = load_scenario(scenario).cameras
    except (ScenarioError, OSError, ValueError) as err:
        raise SuiteError(f"--scenario: {err}") from None
    return ["camera/points", *(f"{name}/points" for name, _ in cameras if name != "camera")]


def _scenario_param(scenario: str) -> str:
    """The sim's ``scenario`` parameter: the name as given, or the file's absolute path. Raises SuiteError."""
    from sim_bridge.scenario import ScenarioError
    from sim_bridge.scenario_files import find_scenario_file

    try:
        path = find_scenario_file(scenario)
    except ScenarioError as err:
        raise SuiteError(f"--scenario: {err}") from None
    return scenario if path.stem == scenario else str(path.resolve())


def _node_list(args: argparse.Namespace) -> list[str]:
    nodes = [n.strip() for n in args.nodes.split(",") if n.strip()]
    if not nodes:
        raise SuiteError("--nodes: no node given")
    unknown = [n for n in nodes if n not in NODES]
    if unknown:
        raise SuiteError(f"--nodes: unknown node {unknown[0]!r}; choose from: {', '.join(sorted(NODES))}")
    if len(set(nodes)) != len(nodes):
        raise SuiteError(f"--nodes: a node is named twice in {args.nodes!r}")
    if args.with_ompl:
        if "ompl_planner" not in NODES:
            raise SuiteError(
                "--with-ompl: the ompl_planner node is not available in this installation "
                f"(registered nodes: {', '.join(sorted(NODES))})"
            )
        if "ompl_planner" not in nodes:
            nodes.append("ompl_planner")
    return nodes


def _executor(args: argparse.Namespace, nodes: list[str]) -> str:
    """The execution source of the suite (``none`` for no node). Raises SuiteError for one not in the suite."""
    if args.execute is None:
        return "planner" if "planner" in nodes else "none"
    if args.execute != "none" and args.execute not in nodes:
        raise SuiteError(f"--execute {args.execute}: the node is not in the suite ({', '.join(nodes)})")
    return args.execute


def build_suite(args: argparse.Namespace) -> Supervisor:
    """The Supervisor for the parsed arguments. Raises SuiteError with a message for the user."""
    nodes = _node_list(args)
    params: dict[str, list[str]] = {}
    if "sim" in nodes:
        params["sim"] = [f"scenario:={_scenario_param(args.scenario)}"]
        topics = scenario_cloud_topics(args.scenario)
        if len(topics) > 1:  # the consumers fuse every camera of the scenario
            for node in CLOUD_CONSUMERS:
                if node in nodes:
                    params.setdefault(node, []).append(f"cloud_topics:=[{','.join(topics)}]")
    executor = _executor(args, nodes)
    for node in EXECUTION_SOURCES:
        if node in nodes:
            params.setdefault(node, []).append(f"{ENABLING[node]}:={'true' if node == executor else 'false'}")
    for text in args.param:
        node, assignment = parse_param(text)
        if node not in nodes:
            raise SuiteError(f"--param {text!r}: node {node!r} is not in the suite ({', '.join(nodes)})")
        name, _, value = assignment.partition(":=")
        if node != executor and ENABLING.get(node) == name and value.strip().lower() == "true":
            raise SuiteError(
                f"--param {text!r}: {executor if executor != 'none' else 'no node'} executes (one command source "
                f"at a time); use --execute {node}"
            )
        params.setdefault(node, []).append(assignment)  # after the defaults above, so the user's wins
    env = suite_env(args.domain_id, args.headless)
    specs = suite_specs(nodes, params, env)
    if args.view:
        from latent_planner_ros.view.process import view_spec

        specs.append(view_spec(args.view_port, env))
    if args.record is not None and args.record.exists() and (not args.record.is_dir() or any(args.record.iterdir())):
        raise SuiteError(f"--record {args.record}: exists and is not empty (a bag is written into a new directory)")
    return Supervisor(specs)


def run_suite(suite: Supervisor, args: argparse.Namespace, stop: threading.Event, force: threading.Event) -> int:
    """Start, wait until up, watch, stop. Returns the exit code (see the module docstring)."""
    from latent_planner_ros.evaluation.probes.graph_probe import GraphProbe

    names = [s.name for s in suite.specs]
    domain = args.domain_id if args.domain_id is not None else os.environ.get("ROS_DOMAIN_ID", "0")
    suite.log(f"starting {', '.join(names)} on ROS_DOMAIN_ID={domain}")
    code = 0
    recorder = None
    try:
        suite.start()
        if args.record is not None:
            from latent_planner_ros.nodes.bag_recorder import RecorderSession

            recorder = RecorderSession(args.record, args.domain_id)
            suite.log(f"recording every topic into {args.record}")
        with GraphProbe(domain_id=args.domain_id) as probe:
            ready = suite.wait_ready(probe.ready_nodes, args.startup_timeout, stop)
        if ready:
            until = f"for {args.duration:g} s" if args.duration is not None else "until Ctrl-C"
            suite.log(f"all {len(names)} nodes are up; running {until}")
            if args.view:
                suite.log(f"the view: http://localhost:{args.view_port}")
            exited = suite.watch(stop, args.duration)
            if exited is not None:
                name, returncode = exited
                suite.log(f"error: node {name} exited unexpectedly with {describe_exit(returncode)}")
                code = 1
    except StartupError as err:
        suite.log(f"error: {err}")
        code = 1
    finally:
        if recorder is not None:
            bag = recorder.close()
            suite.log(f"bag {args.record}: {bag.message_count} messages on {len(bag.topics)} topics")
        running = [n for n in suite.pids if n not in suite.exited()]
        if running:
            suite.log(f"stopping {', '.join(running)}")
        codes = suite.stop(force=force)
        suite.log("stopped: " + ", ".join(f"{n} ({describe_exit(c)})" for n, c in codes.items()))
    return code


def main(argv: list[str] | None = None) -> int:
    """Entry point: `argv` are the arguments after ``launch``. Returns the exit code."""
    args = parse_args(sys.argv[1:] if argv is None else list(argv))
    try:
        suite = build_suite(args)
    except SuiteError as err:
        print(f"latent-planner launch: error: {err}", file=sys.stderr)
        return 2

    stop, force = threading.Event(), threading.Event()

    def on_signal(signum, frame) -> None:
        if stop.is_set():
            force.set()
            suite.log(f"{signal.Signals(signum).name} again: killing the suite")
        else:
            stop.set()
            suite.log(f"{signal.Signals(signum).name}: stopping the suite")

    previous = {sig: signal.signal(sig, on_signal) for sig in (signal.SIGINT, signal.SIGTERM)}
    try:
        return run_suite(suite, args, stop, force)
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler)


if __name__ == "__main__":
    sys.exit(main())

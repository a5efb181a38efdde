"""``python -m latent_planner_ros <command>`` (also the ``latent-planner`` console script).

Commands:
    run <node> [args...]       start one node (ROS arguments pass through)
    launch [args...]           start the node suite as processes
    train <model> [args...]    train a model (vae, ...)
    bench <suite> --out DIR    run a benchmark; writes DIR/<suite>.json, a markdown report and PNGs
    demo                       the main job of the README
    view                       the live 3D view of the suite in the browser
    record DIR                 record the suite's topics into a rosbag2 MCAP bag
    replay BAG                 publish a recorded bag back onto the graph (--view: and show it)
    info                       print a summary of the robot model
"""

from __future__ import annotations

import argparse
import importlib
import sys

from latent_planner_ros.registry import BENCH, NODES, TRAIN


def _load(target: str):
    module, func = target.split(":")
    return getattr(importlib.import_module(module), func)


def _dispatch(kind: str, table: dict[str, str], name: str, rest: list[str]) -> int:
    if name not in table:
        print(f"unknown {kind} {name!r}; choose one of: {', '.join(sorted(table))}", file=sys.stderr)
        return 2
    from latent_planner_ros.batch.job import ClusterError

    try:
        return int(_load(table[name])(rest) or 0)
    except ClusterError as err:  # --cluster: Ray missing, or the cluster cannot be joined
        print(f"[latent-planner {name}] {err}", file=sys.stderr)
        return 2


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else list(argv)
    parser = argparse.ArgumentParser(
        prog="latent-planner", description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    sub = parser.add_subparsers(dest="command", required=True)
    for name, helptext, choices in (
        ("run", "start one node", NODES),
        ("train", "train a model", TRAIN),
        ("bench", "run a benchmark suite", BENCH),
    ):
        p = sub.add_parser(name, help=helptext, add_help=False)
        p.add_argument("target", choices=sorted(choices), metavar="{" + ",".join(sorted(choices)) + "}")
    sub.add_parser("launch", help="start the node suite", add_help=False)
    sub.add_parser("demo", help="run the main job", add_help=False)
    sub.add_parser("view", help="serve the live 3D view on localhost", add_help=False)
    sub.add_parser("record", help="record the suite's topics into a bag", add_help=False)
    sub.add_parser("replay", help="publish a recorded bag back onto the graph", add_help=False)
    sub.add_parser("info", help="print a summary of the robot model")
    args, rest = parser.parse_known_args(argv)

    if args.command == "run":
        sys.argv = [args.target, *rest]
        return int(_load(NODES[args.target])() or 0)
    if args.command == "train":
        return _dispatch("model", TRAIN, args.target, rest)
    if args.command == "bench":
        return _dispatch("bench suite", BENCH, args.target, rest)
    if args.command == "launch":
        return int(_load("latent_planner_ros.launcher:main")(rest) or 0)
    if args.command == "demo":
        return int(_load("latent_planner_ros.demo:main")(rest) or 0)
    if args.command == "view":
        return int(_load("latent_planner_ros.nodes.view:main")(rest) or 0)
    if args.command == "record":
        return int(_load("latent_planner_ros.nodes.bag_recorder:main")(rest) or 0)
    if args.command == "replay":
        return int(_load("latent_planner_ros.nodes.bag_player:main")(rest) or 0)
    if args.command == "info":
        from latent_planner_ros.robot.summary import robot_summary

        print(robot_summary())
        return 0
    parser.error(f"unknown command {args.command}")
    return 2

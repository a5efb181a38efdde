"""player: publishes a recorded bag (recording/bag_reader.py) back onto the graph with its original timing.

Every topic of the bag (or those named with ``--topics``) gets a publisher with the QoS it was recorded with;
the serialized messages are published as they are, each when as much time has passed since the first as between
their receipt times in the bag (``--rate`` scales that). ``/clock`` is replayed like any topic, so nodes with
``use_sim_time`` follow the recorded simulated time. With ``--view`` the live view (nodes/view.py) runs in this
process and shows the replay; it stays up after the bag ends, until Ctrl-C.

    python -m latent_planner_ros replay BAG [--rate F] [--topics a,b] [--delay S] [--wait-subscribers S]
        [--view [--port N]] [--domain-id N]
"""

from __future__ import annotations

import argparse
import sys
import threading
import time

import rclpy
from rclpy.context import Context
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.signals import SignalHandlerOptions

from latent_planner_ros.nodes.bag_recorder import message_class, qos_profile
from latent_planner_ros.recording.bag_reader import BagTopic, bag_messages, bag_topics, paced


class BagPlayer(Node):
    """Publishers for the topics of a bag; :meth:`play` publishes its messages paced."""

    def __init__(self, topics: list[BagTopic], name: str = "player", **kwargs):
        super().__init__(name, start_parameter_services=False, **kwargs)
        self.publishers_ = {}
        self.sent = dict.fromkeys((t.name for t in topics), 0)
        for topic in topics:
            try:
                cls = message_class(topic.type_name)
            except (ImportError, AttributeError, ValueError) as err:
                self.get_logger().warning(f"not replaying {topic.name}: type {topic.type_name} not installed ({err})")
                continue
            self.publishers_[topic.name] = self.create_publisher(cls, topic.name, qos_profile(topic.qos))

    def wait_for_subscribers(self, timeout_s: float) -> bool:
        """Wait until every publisher has a subscriber (at most timeout_s [s]); True if they all have one."""
        end = time.monotonic() + timeout_s
        while any(p.get_subscription_count() == 0 for p in self.publishers_.values()):
            if time.monotonic() > end:
                return False
            time.sleep(0.05)
        time.sleep(0.2)  # the subscriptions' side of the match
        return True

    def play(self, path, rate: float = 1.0, stop: threading.Event | None = None) -> int:
        """Publish the bag's messages of our topics with their timing; returns how many were published."""
        n = 0
        for topic, _, data in paced(bag_messages(path, list(self.publishers_)), rate):
            if stop is not None and stop.is_set():
                break
            self.publishers_[topic].publish(bytes(data))
            self.sent[topic] += 1
            n += 1
        return n


def parse_args(argv: list[str]) -> argparse.Namespace:
    p = argparse.ArgumentParser(prog="latent-planner replay", description=__doc__.split("\n\n")[0])
    p.add_argument("bag", help="a bag directory (with metadata.yaml) or a .mcap file")
    p.add_argument("--rate", type=float, default=1.0, metavar="F", help="playback speed factor (default 1)")
    p.add_argument("--topics", metavar="a,b", help="comma-separated topics to replay (default: all)")
    p.add_argument("--delay", type=float, default=1.0, metavar="S", help="wait before playing, for discovery (1 s)")
    p.add_argument(
        "--wait-subscribers",
        type=float,
        default=0.0,
        metavar="S",
        help="after --delay, wait up to S s until every replayed topic has a subscriber (default 0)",
    )
    p.add_argument("--view", action="store_true", help="show the replay in the live view (stays up until Ctrl-C)")
    p.add_argument("--port", type=int, default=8080, help="the view's port (default 8080)")
    p.add_argument("--domain-id", type=int, metavar="N", help="ROS_DOMAIN_ID (default: the environment's)")
    args = p.parse_args(argv)
    if args.rate <= 0 or args.delay < 0:
        p.error("--rate must be positive and --delay not negative")
    return args


def main(argv: list[str] | None = None) -> int:
    args = parse_args(sys.argv[1:] if argv is None else list(argv))
    try:
        topics = bag_topics(args.bag)
    except (FileNotFoundError, ValueError, KeyError) as err:
        print(f"latent-planner replay: error: {err}", file=sys.stderr)
        return 2
    if args.topics:
        wanted = {t.strip() if t.strip().startswith("/") else "/" + t.strip() for t in args.topics.split(",")}
        topics = [t for t in topics if t.name in wanted]
    context = Context()
    rclpy.init(context=context, domain_id=args.domain_id, signal_handler_options=SignalHandlerOptions.NO)
    executor = SingleThreadedExecutor(context=context)
    player = BagPlayer(topics, context=context)
    view, stop = None, threading.Event()
    try:
        if args.view:
            from latent_planner_ros.nodes.view import ViewNode

            view = ViewNode(port=args.port, context=context)
            executor.add_node(view)
            threading.Thread(target=_spin, args=(executor, stop), daemon=True).start()
        time.sleep(args.delay)
        if args.wait_subscribers > 0 and not player.wait_for_subscribers(args.wait_subscribers):
            print(f"[replay] not every topic has a subscriber after {args.wait_subscribers:g} s: playing", flush=True)
        total = sum(t.count for t in topics)
        print(f"[replay] {args.bag}: {total} messages on {len(topics)} topics at rate {args.rate:g}", flush=True)
        n = player.play(args.bag, args.rate)
        print(f"[replay] done: {n} messages published", flush=True)
        if view is not None:
            print(f"[replay] the view stays up at {view.url} until Ctrl-C", flush=True)
            while True:
                time.sleep(1.0)
    except KeyboardInterrupt:
        pass
    finally:
        stop.set()
        executor.shutdown(timeout_sec=1.0)
        if view is not None:
            view.destroy_node()
        player.destroy_node()
        rclpy.try_shutdown(context=context)
    return 0


def _spin(executor: SingleThreadedExecutor, stop: threading.Event) -> None:
    while not stop.is_set() and executor.context.ok():
        try:
            executor.spin_once(timeout_sec=0.1)
        except Exception:
            if executor.context.ok():
                raise
            return

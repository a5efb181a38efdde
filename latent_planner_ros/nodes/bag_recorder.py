"""recorder node: records the suite's topics into a rosbag2 MCAP bag (recording/bag_writer.py).

Every `DISCOVERY_S` it looks at the graph and subscribes to each new topic (all of them, or those named with
``--topics``; never /rosout, /parameter_events or hidden ones), with the QoS its publishers offer (reliable and
transient-local only when every publisher is). Messages arrive serialized (raw subscriptions) and go into the bag
as they are, stamped with their receipt time (wall clock, as ``ros2 bag record`` does). A topic whose type has no
installed ``.msg`` file is skipped with a warning. Publishes ~/status (diagnostic_msgs/DiagnosticArray, 1 Hz:
topics, messages, bytes). The bag is closed (its summary and metadata.yaml written) when the node stops.

    python -m latent_planner_ros record DIR [--topics a,b] [--overwrite] [--ros-args ...]
"""

from __future__ import annotations

import argparse
import importlib
import sys
import time
from functools import partial

from diagnostic_msgs.msg import DiagnosticArray
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy

from latent_planner_ros.nodes.node_main import run_node
from latent_planner_ros.recording.bag_writer import BagWriter, TopicQos
from latent_planner_ros.recording.msgdef import MessageDefinitionError
from msg_adapters import status_array

DISCOVERY_S = 0.25
"""[s] period of the look for new topics."""
SKIPPED = frozenset({"/rosout", "/parameter_events"})


def message_class(type_name: str):
    """The Python class of ``package/msg/Type``; ImportError/AttributeError if not installed."""
    package, _, name = type_name.split("/")
    return getattr(importlib.import_module(f"{package}.msg"), name)


def offered_qos(node: Node, topic: str) -> TopicQos:
    """The QoS a subscriber should use to hear every publisher of `topic` (and that a replay offers)."""
    infos = node.get_publishers_info_by_topic(topic)
    if not infos:
        return TopicQos()
    profiles = [i.qos_profile for i in infos]
    return TopicQos(
        reliable=all(p.reliability == ReliabilityPolicy.RELIABLE for p in profiles),
        transient_local=all(p.durability == DurabilityPolicy.TRANSIENT_LOCAL for p in profiles),
        depth=max(10, *(int(p.depth) for p in profiles)),
    )


def qos_profile(qos: TopicQos) -> QoSProfile:
    return QoSProfile(
        depth=qos.depth,
        reliability=ReliabilityPolicy.RELIABLE if qos.reliable else ReliabilityPolicy.BEST_EFFORT,
        durability=DurabilityPolicy.TRANSIENT_LOCAL if qos.transient_local else DurabilityPolicy.VOLATILE,
    )


class BagRecorder(Node):
    """Records topics into `bag` (see the module docstring); `topics` None = every topic."""

    def __init__(self, bag: BagWriter, topics: list[str] | None = None, name: str = "recorder", **kwargs):
        super().__init__(name, **kwargs)
        self.bag = bag
        self.wanted = None if topics is None else {t if t.startswith("/") else f"/{t}" for t in topics}
        self._skipped: set[str] = set()
        self._bytes = 0
        self.pub_status = self.create_publisher(DiagnosticArray, "~/status", 10)
        self.create_timer(DISCOVERY_S, self._discover)
        self.create_timer(1.0, self._publish_status)
        self._discover()

    def _discover(self) -> None:
        for topic, types in self.get_topic_names_and_types():
            if topic in self.bag.topics or topic in self._skipped or topic in SKIPPED or "/_" in topic:
                continue
            if self.wanted is not None and topic not in self.wanted:
                continue
            if topic.startswith(self.get_fully_qualified_name() + "/"):
                continue  # our own status
            try:
                if len(types) != 1:
                    raise MessageDefinitionError(f"more than one type: {', '.join(types)}")
                cls = message_class(types[0])
                qos = offered_qos(self, topic)
                self.bag.add_topic(topic, types[0], qos)
            except (MessageDefinitionError, ImportError, AttributeError, ValueError) as err:
                self._skipped.add(topic)
                self.get_logger().warning(f"not recording {topic}: {err}")
                continue
            self.create_subscription(cls, topic, partial(self._on_message, topic), qos_profile(qos), raw=True)
            self.get_logger().info(f"recording {topic} ({types[0]})")

    def _on_message(self, topic: str, data: bytes) -> None:
        if not self.bag.closed:
            self.bag.write(topic, time.time_ns(), data)
            self._bytes += len(data)

    def _publish_status(self) -> None:
        values = {"bag": str(self.bag.path), "topics": len(self.bag.topics), "messages": self.bag.message_count}
        values["bytes"] = self._bytes
        msg = status_array(self.get_name(), 0, f"recording {len(self.bag.topics)} topics", values)
        self.pub_status.publish(msg)

    def destroy_node(self) -> None:
        self.bag.close()
        self.get_logger().info(
            f"bag {self.bag.path}: {self.bag.message_count} messages on {len(self.bag.topics)} topics"
        )
        super().destroy_node()


def parse_args(argv: list[str]) -> argparse.Namespace:
    p = argparse.ArgumentParser(prog="latent-planner record", description=__doc__.split("\n\n")[0])
    p.add_argument("bag", help="the bag directory to write (must not exist, or be empty)")
    p.add_argument("--topics", metavar="a,b", help="comma-separated topics to record (default: every topic)")
    p.add_argument("--overwrite", action="store_true", help="replace an existing bag directory")
    return p.parse_args(argv)


def main(argv: list[str] | None = None) -> int:
    """Entry point: `argv` = arguments after ``record`` (ROS arguments after ``--ros-args`` are passed on)."""
    argv = sys.argv[1:] if argv is None else list(argv)
    ours, ros = (
        (argv[: argv.index("--ros-args")], argv[argv.index("--ros-args") :]) if "--ros-args" in argv else (argv, [])
    )
    args = parse_args(ours)
    topics = [t.strip() for t in args.topics.split(",") if t.strip()] if args.topics else None
    try:
        bag = BagWriter(args.bag, overwrite=args.overwrite)
    except (FileExistsError, OSError) as err:
        print(f"latent-planner record: error: {err}", file=sys.stderr)
        return 2
    sys.argv = ["recorder", *ros]
    try:
        return run_node("recorder", lambda: BagRecorder(bag, topics), ())
    finally:
        bag.close()


class RecorderSession:
    """A BagRecorder in this process (own rclpy context, background thread, no signal handlers), for the demo,
    the launcher and the conveyor benchmark: ``with RecorderSession("out/bag", domain_id): ...``; the bag is
    complete once the session is closed.

    Args:
        path: the bag directory; overwrite: replace an existing one (else FileExistsError).
        domain_id: the ROS domain; None uses ``$ROS_DOMAIN_ID``.
        topics: topics to record; None = every topic.
    """

    def __init__(self, path, domain_id: int | None = None, topics: list[str] | None = None, overwrite: bool = False):
        from latent_planner_ros.evaluation.probes.probe_session import ProbeSession

        self.bag = BagWriter(path, overwrite=overwrite)
        self._session = ProbeSession(
            lambda context: BagRecorder(self.bag, topics, context=context, start_parameter_services=False),
            "recorder",
            domain_id,
        )

    def close(self) -> BagWriter:
        """Stop recording and close the bag; returns the writer (its topics and counts)."""
        self._session.close()
        self.bag.close()
        return self.bag

    def __enter__(self) -> RecorderSession:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

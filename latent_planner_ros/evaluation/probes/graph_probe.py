"""GraphProbe: a hidden node that lists the nodes of the ROS graph (the launcher's readiness check).

A node counts as ready once it publishes a topic of its own: every node has /rosout and /parameter_events
from its constructor, but our nodes create their publishers only after their parameters, scenario or
checkpoints have loaded, so a node that fails at start-up is never reported ready.

It lives in its own rclpy context and installs no signal handlers, so the program using it keeps its own
Ctrl-C handling. The graph is kept up to date by the middleware's discovery; no spinning is needed.
"""

from __future__ import annotations

import rclpy
from rclpy.context import Context
from rclpy.node import Node
from rclpy.signals import SignalHandlerOptions

COMMON_TOPICS = frozenset({"/rosout", "/parameter_events"})
"""Topics every node publishes from its constructor on."""


class GraphProbe:
    """Reads the names of the nodes on one ROS domain.

    Args:
        domain_id: the ROS domain; None uses ``$ROS_DOMAIN_ID`` (or 0).
        name: node name (a leading underscore hides it from ``ros2 node list``).
    """

    def __init__(self, domain_id: int | None = None, name: str = "_launch_probe"):
        self.context = Context()
        rclpy.init(context=self.context, domain_id=domain_id, signal_handler_options=SignalHandlerOptions.NO)
        self.node = Node(name, context=self.context, start_parameter_services=False)

    def node_names(self) -> set[str]:
        """Names (without namespace) of the nodes currently discovered, this probe excluded."""
        return set(self.node.get_node_names()) - {self.node.get_name()}

    def ready_nodes(self) -> set[str]:
        """Names of the discovered nodes that publish at least one topic besides /rosout and /parameter_events."""
        ready = set()
        for name, namespace in self.node.get_node_names_and_namespaces():
            if name == self.node.get_name() or name in ready:
                continue
            try:
                topics = self.node.get_publisher_names_and_types_by_node(name, namespace)
            except Exception:  # the node left the graph between the two calls
                continue
            if any(topic not in COMMON_TOPICS for topic, _ in topics):
                ready.add(name)
        return ready

    def close(self) -> None:
        self.node.destroy_node()
        rclpy.try_shutdown(context=self.context)

    def __enter__(self) -> GraphProbe:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

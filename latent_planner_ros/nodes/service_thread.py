"""Services of a node answered on a thread of their own, so a long request never stalls the node's timers.

A second, helper node (`<node>_services`) holds the services under the owner's names (e.g. `/planner/plan`)
and is spun by its own single-threaded executor on a daemon thread; the owner keeps its single-threaded
executor for the control loop. (rclpy's MultiThreadedExecutor would also keep a timer ticking during a long
callback, but on the conveyor it cost the planner's 10 Hz loop tick time and missed control periods; the figures
are in docs/benchmark.md.) The callbacks run on the service thread: they must guard shared state.
"""

from __future__ import annotations

import threading
from collections.abc import Callable

import rclpy
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from rclpy.node import Node


class ServiceThread:
    """A helper node for `owner`'s services, spun on its own thread.

    Args:
        owner: the node whose services these are (their names are `<owner's fully qualified name>/<name>`).
    """

    def __init__(self, owner: Node):
        self.owner_name = owner.get_fully_qualified_name()
        self.node = rclpy.create_node(
            f"{owner.get_name()}_services",
            namespace=owner.get_namespace(),
            context=owner.context,
            start_parameter_services=False,
        )
        self.executor = SingleThreadedExecutor(context=owner.context)
        self.executor.add_node(self.node)
        self._thread = threading.Thread(target=self._spin, name=f"{owner.get_name()}-services", daemon=True)
        self._thread.start()

    def create_service(self, srv_type, name: str, callback: Callable):
        """A service whose callback runs on this thread; `~/x` names the owner's private `<owner>/x`."""
        if name.startswith("~/"):
            name = f"{self.owner_name}/{name[2:]}"
        return self.node.create_service(srv_type, name, callback)

    def _spin(self) -> None:
        try:
            self.executor.spin()
        except ExternalShutdownException:
            pass

    def close(self) -> None:
        """Stop the thread (after the callback it runs, if any) and destroy the helper node."""
        self.executor.shutdown(timeout_sec=1.0)
        self._thread.join(timeout=1.0)
        self.node.destroy_node()

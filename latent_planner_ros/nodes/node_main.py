"""The shared main() of the long-running nodes: start, spin, and shut down cleanly on Ctrl-C or SIGTERM.

A node that seems stuck can be asked where it is: SIGUSR1 (`kill -USR1 PID`) prints every thread's Python
stack to stderr and the node carries on.
"""

from __future__ import annotations

import faulthandler
import signal
import sys
import time
from collections.abc import Callable

import rclpy
from rclpy.executors import ExternalShutdownException
from rclpy.logging import get_logger
from rclpy.node import Node

from latent_planner_ros.params.ros import undeclared_overrides

SHUTDOWN_GRACE_S = 0.5
"""after an error in spin, how long [s] to wait for a shutdown that a signal has started (rclpy's signal handler
wakes the executor, which may fail to take a message from a subscription being torn down, before the context
says it is shut down)"""


def _shutting_down(grace_s: float = SHUTDOWN_GRACE_S) -> bool:
    """True if the rclpy context is shut down now or within grace_s [s]."""
    deadline = time.monotonic() + grace_s
    while rclpy.ok():
        if time.monotonic() > deadline:
            return False
        time.sleep(0.01)
    return True


def run_node(name: str, factory: Callable[[], Node], startup_errors: tuple[type[BaseException], ...]) -> int:
    """Create the node with `factory` and spin it until shutdown; the process exit code.

    An error in `startup_errors` while creating the node (a bad parameter, a missing checkpoint) is logged as
    "cannot start: ..." and gives exit code 2; start-up parameters the node does not have are logged as ignored.
    Ctrl-C or an external shutdown gives 0. Any other error is raised, except one racing the shutdown (a callback
    publishing after SIGTERM).
    """
    faulthandler.register(signal.SIGUSR1, all_threads=True)
    rclpy.init(args=sys.argv)
    node = None
    try:
        try:
            node = factory()
        except startup_errors as err:
            get_logger(name).error(f"cannot start: {err}")
            return 2
        unknown = undeclared_overrides(node)
        if unknown:
            node.get_logger().warning(
                f"ignored: start-up parameters this node does not have: {', '.join(unknown)} "
                "(docs/nodes.md lists every node's parameters)"
            )
        rclpy.spin(node)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    except Exception:
        if not _shutting_down():  # a real error; after SIGTERM/SIGINT a callback may race the shutdown: ignore that
            raise
    finally:
        if node is not None:
            node.destroy_node()
        rclpy.try_shutdown()
    return 0

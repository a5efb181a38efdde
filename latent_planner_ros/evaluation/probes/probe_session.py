"""A probe node spun in background threads on its own ROS context: the base of the test and bench sessions."""

from __future__ import annotations

import threading
from collections.abc import Callable

import rclpy
from rclpy.context import Context
from rclpy.executors import ExternalShutdownException, ShutdownException, SingleThreadedExecutor
from rclpy.node import Node
from rclpy.signals import SignalHandlerOptions


class ProbeSession:
    """Owns a context, the node `make_node(context)` builds, an executor thread and any `extra` loop threads.

    Args:
        make_node: builds the probe node on the given context.
        name: the executor thread's name.
        domain_id: the ROS domain; None uses ``$ROS_DOMAIN_ID``.
        extra: more (name, target) threads to run until close(); they should return once `self._stop` is set.
    """

    def __init__(
        self,
        make_node: Callable[[Context], Node],
        name: str,
        domain_id: int | None = None,
        extra: tuple[tuple[str, Callable[[], None]], ...] = (),
    ):
        self.context = Context()
        rclpy.init(context=self.context, domain_id=domain_id, signal_handler_options=SignalHandlerOptions.NO)
        self.node = make_node(self.context)
        self.executor = SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.node)
        self._stop = threading.Event()
        targets = ((name, self._spin), *extra)
        self._threads = [threading.Thread(target=target, name=n, daemon=True) for n, target in targets]
        for thread in self._threads:
            thread.start()

    def _spin(self) -> None:
        try:
            while not self._stop.is_set() and self.context.ok():
                self.executor.spin_once(timeout_sec=0.1)
        except (ExternalShutdownException, ShutdownException):
            pass
        except Exception:
            if self.context.ok():
                raise

    def call(self, client, request, timeout_s: float = 30.0):
        """Call a service and wait for the answer; TimeoutError if it is not there or does not answer."""
        if not client.wait_for_service(timeout_sec=timeout_s):
            raise TimeoutError(f"service {client.srv_name} is not available")
        done = threading.Event()
        future = client.call_async(request)
        future.add_done_callback(lambda _: done.set())
        if not done.wait(timeout_s) or future.result() is None:
            raise TimeoutError(f"no answer from {client.srv_name} within {timeout_s:g} s")
        return future.result()

    def close(self) -> None:
        """Stop the threads, the executor and the node, and shut the context down."""
        self._stop.set()
        for thread in self._threads:
            thread.join(timeout=2.0)
        self.executor.shutdown(timeout_sec=1.0)
        self.node.destroy_node()
        rclpy.try_shutdown(context=self.context)

    def __enter__(self):
        return self

    def __exit__(self, *exc) -> None:
        self.close()

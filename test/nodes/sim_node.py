"""A sim node (sim_bridge.node.SimNode) in the test's own process, with small camera images."""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager

import rclpy

SMALL = ["-p", "camera.width:=64", "-p", "camera.height:=48"]
"""64 x 48 depth images: the camera's parameters as configured, a fraction of the rendering"""


def make_sim(*args: str):
    """A SimNode started with ROS arguments `args` (after SMALL) in a fresh rclpy context; the context is shut
    down again if the node refuses to start."""
    rclpy.init(args=["--ros-args", *SMALL, *args])
    from sim_bridge.node import SimNode

    try:
        return SimNode()
    except BaseException:
        rclpy.shutdown()
        raise


@contextmanager
def running_sim(*args: str) -> Iterator:
    """make_sim(*args) for the block, closed and its context shut down after it."""
    node = make_sim(*args)
    try:
        yield node
    finally:
        node.close()
        node.destroy_node()
        rclpy.shutdown()

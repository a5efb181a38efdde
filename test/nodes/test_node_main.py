"""run_node tells an error racing a signal's shutdown from a real one: it waits a moment for the context to close."""

import threading

import rclpy

from latent_planner_ros.nodes.node_main import _shutting_down


def test_an_open_context_is_not_shutting_down_and_one_closing_soon_is():
    rclpy.init()
    try:
        assert not _shutting_down(0.05)
        timer = threading.Timer(0.1, rclpy.try_shutdown)
        timer.start()
        assert _shutting_down(2.0)
        timer.join()
        assert _shutting_down(0.0)  # already shut down
    finally:
        rclpy.try_shutdown()

"""The README's main job (`make demo`).

Until the closed-loop suite exists this runs the most complete pipeline available: it prints the robot
model, starts the `robot_info` node as its own process, and receives what it publishes over ROS 2
(robot_description and joint_states), as any other node of the suite would.
"""

from __future__ import annotations

import os
import subprocess
import sys
import time

import numpy as np

from latent_planner_ros.robot.summary import robot_summary

TIMEOUT_S = 30.0


def receive_from_robot_info(timeout_s: float = TIMEOUT_S) -> tuple[str, np.ndarray]:
    """Start robot_info in a subprocess and return (description, q (7,)) received from it."""
    import rclpy
    from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
    from sensor_msgs.msg import JointState
    from std_msgs.msg import String

    from msg_adapters import joint_state_to_q

    got: dict = {}
    proc = subprocess.Popen([sys.executable, "-m", "latent_planner_ros", "run", "robot_info"], env=os.environ.copy())
    rclpy.init()
    try:
        node = rclpy.create_node("demo_listener")
        latched = QoSProfile(
            depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL, reliability=ReliabilityPolicy.RELIABLE
        )
        node.create_subscription(String, "robot_description", lambda m: got.setdefault("description", m.data), latched)
        node.create_subscription(JointState, "joint_states", lambda m: got.setdefault("q", joint_state_to_q(m)[0]), 10)
        deadline = time.monotonic() + timeout_s
        while len(got) < 2 and time.monotonic() < deadline:
            if proc.poll() is not None:
                raise RuntimeError(f"robot_info exited early with code {proc.returncode}")
            rclpy.spin_once(node, timeout_sec=0.1)
        node.destroy_node()
    finally:
        rclpy.try_shutdown()
        proc.terminate()
        try:
            proc.wait(timeout=10)
        except subprocess.TimeoutExpired:
            proc.kill()
    if len(got) < 2:
        raise TimeoutError(f"nothing received from robot_info within {timeout_s:.0f} s (got {sorted(got)})")
    return got["description"], got["q"]


def main(argv: list[str] | None = None) -> int:
    print(robot_summary())
    print("\n[demo] starting the robot_info node and listening to it over ROS 2 ...")
    try:
        description, q = receive_from_robot_info()
    except (RuntimeError, TimeoutError) as e:
        print(f"[demo] failed: {e}", file=sys.stderr)
        return 1
    print(f"[demo] robot_description received ({len(description.splitlines())} lines)")
    print(f"[demo] joint_states received: q = {np.round(q, 3).tolist()} rad")
    print("[demo] done")
    return 0

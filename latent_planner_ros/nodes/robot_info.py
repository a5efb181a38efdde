"""robot_info node: the robot model summary and the ready configuration, for a first look at the graph.

Publishes:
    robot_description (std_msgs/String, transient local): the text of `robot_summary()`, once;
        late subscribers still receive it.
    joint_states (sensor_msgs/JointState): Q_READY [rad] for panda_joint1..7 at 10 Hz.

Usage:
    python -m latent_planner_ros run robot_info [--once] [--ros-args ...]
    ros2 run latent_planner_ros robot_info [--once]

--once publishes, waits up to ~2 s for subscribers to receive the messages, then exits 0.
Otherwise the node runs until Ctrl-C.
"""

from __future__ import annotations

import argparse
import sys
import time

import rclpy
from rclpy.duration import Duration
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from rclpy.utilities import remove_ros_args
from sensor_msgs.msg import JointState
from std_msgs.msg import String

from latent_planner_ros.robot.limits import Q_READY
from latent_planner_ros.robot.summary import robot_summary
from msg_adapters import q_to_joint_state

RATE_HZ = 10.0
"""joint_states publishing rate [Hz]."""

ONCE_WAIT_S = 2.0
"""With --once: how long to wait for subscribers to receive the messages [s]."""

LATCHED = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL, reliability=ReliabilityPolicy.RELIABLE)


class RobotInfoNode(Node):
    """Publishes `description` once (latched) on robot_description and Q_READY on joint_states."""

    def __init__(self, description: str):
        super().__init__("robot_info")
        self.description_pub = self.create_publisher(String, "robot_description", LATCHED)
        self.joint_state_pub = self.create_publisher(JointState, "joint_states", 10)
        self.description_pub.publish(String(data=description))
        self.publish_joint_state()
        self.timer = self.create_timer(1.0 / RATE_HZ, self.publish_joint_state)

    def publish_joint_state(self) -> None:
        self.joint_state_pub.publish(q_to_joint_state(Q_READY, stamp=self.get_clock().now().to_msg()))

    def has_subscribers(self) -> bool:
        return self.description_pub.get_subscription_count() > 0 and self.joint_state_pub.get_subscription_count() > 0


def _parse_args(argv: list[str]) -> argparse.Namespace:
    parser = argparse.ArgumentParser(
        prog="robot_info", description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--once", action="store_true", help="publish once, wait up to ~2 s for delivery, exit")
    return parser.parse_args(argv)


def _run_once(node: RobotInfoNode, executor: SingleThreadedExecutor) -> None:
    """Keep publishing until both topics have a subscriber (or the wait ends), then wait for delivery."""
    deadline = time.monotonic() + ONCE_WAIT_S
    while time.monotonic() < deadline and not node.has_subscribers():
        executor.spin_once(timeout_sec=0.05)
    node.publish_joint_state()  # one more, now that any subscriber has been matched
    remaining = max(deadline - time.monotonic(), 0.2)
    for pub in (node.description_pub, node.joint_state_pub):
        if pub.get_subscription_count() > 0:
            pub.wait_for_all_acked(Duration(seconds=remaining))


def main() -> int:
    """Entry point (reads sys.argv, ROS arguments included). Returns the exit code: 0, or 2 on bad arguments."""
    args = _parse_args(remove_ros_args(sys.argv)[1:])
    node = None
    try:
        description = robot_summary()
        rclpy.init(args=sys.argv)
        node = RobotInfoNode(description)
        executor = SingleThreadedExecutor()
        executor.add_node(node)
        node.get_logger().info(f"publishing robot_description and joint_states (ready pose) at {RATE_HZ:g} Hz")
        if args.once:
            _run_once(node, executor)
        else:
            executor.spin()
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        if node is not None:
            node.destroy_node()
        rclpy.try_shutdown()
    return 0


if __name__ == "__main__":
    sys.exit(main())

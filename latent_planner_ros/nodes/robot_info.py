"""robot_info node: the robot model as URDF and the ready configuration, for robot_state_publisher and RViz.

Publishes:
    robot_description (std_msgs/String, transient local): the Panda URDF XML (example-robot-data) with the
        joint prefix applied to every link and joint name, once; late subscribers (robot_state_publisher,
        RViz) still receive it.
    joint_states (sensor_msgs/JointState): Q_READY [rad] for <prefix>joint1..7 at 10 Hz.

Parameters: `joint_prefix` (default `panda_`; e.g. `fr3_`), fixed at start-up.

Usage:
    python -m latent_planner_ros run robot_info [--once [--wait S]] [--ros-args ... [--]]
    ros2 run latent_planner_ros robot_info [--once [--wait S]]

--once publishes, waits up to ~2 s (--wait) for subscribers to receive the messages, then exits 0.
Otherwise the node runs until Ctrl-C.
DDS discovery between processes takes 0.1-4 s here: a listener that must not miss the --once
messages should already run and the wait be longer (e.g. --wait 10; it ends as soon as they are delivered).
"""

from __future__ import annotations

import argparse
import sys
import time
from dataclasses import dataclass

import rclpy
from rclpy.duration import Duration
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from rclpy.impl.implementation_singleton import rclpy_implementation
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from rclpy.utilities import remove_ros_args
from sensor_msgs.msg import JointState
from std_msgs.msg import String

from latent_planner_ros.nodes.frames_config import FramesConfig
from latent_planner_ros.params.ros import ConfigParams
from latent_planner_ros.robot.limits import Q_READY
from latent_planner_ros.robot.urdf import panda_urdf
from msg_adapters import q_to_joint_state

RATE_HZ = 10.0
"""joint_states publishing rate [Hz]."""

ONCE_WAIT_S = 2.0
"""With --once: default longest wait for subscribers to receive the messages [s]."""

LATCHED = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL, reliability=ReliabilityPolicy.RELIABLE)


@dataclass
class RobotInfoConfig:
    joint_prefix: str = "panda_"
    """prefix of the link and joint names in the URDF and joint_states (`<prefix>joint1`, `<prefix>link0`)"""

    def __post_init__(self) -> None:
        FramesConfig(joint_prefix=self.joint_prefix)  # the same rule as the planners' frames.joint_prefix


class RobotInfoNode(Node):
    """Publishes the URDF once (latched) on robot_description and Q_READY on joint_states."""

    def __init__(self):
        super().__init__("robot_info")
        params = ConfigParams(self, RobotInfoConfig, read_only=("joint_prefix",))
        self.config = params.config
        self.joint_names = FramesConfig(joint_prefix=self.config.joint_prefix).joint_names
        self.description_pub = self.create_publisher(String, "robot_description", LATCHED)
        self.joint_state_pub = self.create_publisher(JointState, "joint_states", 10)
        self.description_pub.publish(String(data=panda_urdf(self.config.joint_prefix)))
        self.publish_joint_state()
        self.timer = self.create_timer(1.0 / RATE_HZ, self.publish_joint_state)

    def publish_joint_state(self) -> None:
        stamp = self.get_clock().now().to_msg()
        self.joint_state_pub.publish(q_to_joint_state(Q_READY, names=self.joint_names, stamp=stamp))

    def has_subscribers(self) -> bool:
        return self.description_pub.get_subscription_count() > 0 and self.joint_state_pub.get_subscription_count() > 0


def _parse_args(argv: list[str]) -> argparse.Namespace:
    """Our own options from the full command line (program name first, ROS arguments anywhere)."""
    try:
        argv = remove_ros_args(argv)[1:]
    except rclpy_implementation.UnknownROSArgsError as exc:
        print(f"robot_info: error: unknown ROS arguments {exc} (end ROS arguments with --)", file=sys.stderr)
        raise SystemExit(2) from None
    except rclpy_implementation.RCLInvalidROSArgsError as exc:
        print(f"robot_info: error: {exc}", file=sys.stderr)
        raise SystemExit(2) from None
    parser = argparse.ArgumentParser(
        prog="robot_info", description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--once", action="store_true", help="publish, wait for delivery (see --wait), exit 0")
    parser.add_argument(
        "--wait",
        type=float,
        default=ONCE_WAIT_S,
        metavar="S",
        help=f"with --once: longest wait [s] for subscribers to match and acknowledge (default {ONCE_WAIT_S:g})",
    )
    return parser.parse_args(argv)


def _spin_for(executor: SingleThreadedExecutor, seconds: float) -> None:
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        executor.spin_once(timeout_sec=min(0.05, max(end - time.monotonic(), 0.0)))


def _run_once(node: RobotInfoNode, executor: SingleThreadedExecutor, wait_s: float) -> None:
    """Keep publishing until both topics have a subscriber (at most wait_s [s]), then let the messages go out.

    The latched description is waited for until acknowledged. joint_states is a stream whose reliable
    delivery is acknowledged only at the next DDS heartbeat (~3 s with Fast DDS), so after a last sample
    the node spins a moment instead.
    """
    deadline = time.monotonic() + wait_s
    while time.monotonic() < deadline and not node.has_subscribers():
        executor.spin_once(timeout_sec=0.05)
    node.publish_joint_state()  # one more, now that any subscriber has been matched
    if node.description_pub.get_subscription_count() > 0:
        node.description_pub.wait_for_all_acked(Duration(seconds=max(deadline - time.monotonic(), 0.2)))
    _spin_for(executor, 0.2)


def main() -> int:
    """Entry point (reads sys.argv, ROS arguments included). Returns 0; exits 2 on bad arguments."""
    args = _parse_args(sys.argv)
    node = None
    try:
        rclpy.init(args=sys.argv)
        node = RobotInfoNode()
        executor = SingleThreadedExecutor()
        executor.add_node(node)
        node.get_logger().info(
            f"publishing {node.description_pub.topic_name} and {node.joint_state_pub.topic_name} "
            f"(ready pose, {RATE_HZ:g} Hz)"
        )
        if args.once:
            _run_once(node, executor, args.wait)
        else:
            executor.spin()
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    except ValueError as err:  # a refused parameter (ConfigError)
        print(f"robot_info: cannot start: {err}", file=sys.stderr)
        return 2
    finally:
        if node is not None:
            node.destroy_node()
        rclpy.try_shutdown()
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""One command source at a time: the execution sources claim the arm on the ``execution_owner`` topic.

The planner (closed loop, while enabled) and ompl_planner (with ``execute``) both command the arm on
``joint_trajectory``. Each claims the arm when it is enabled: a std_msgs/Header on ``execution_owner`` with its
node name in ``frame_id`` and the wall-clock time of the claim in ``stamp`` (transient local, so a node that
starts later hears the current claim). A node that hears a claim of another node newer than its own disables
itself: enabling one execution source disables the other, and two sources never command at once.
"""

from __future__ import annotations

import math
from collections.abc import Callable

from rclpy.clock import Clock, ClockType
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from std_msgs.msg import Header

QOS = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL, reliability=ReliabilityPolicy.RELIABLE)
"""QoS of `execution_owner` (publisher and subscription): a node that starts later hears the newest claim."""


class ExecutionOwner:
    """A node's claims of the arm and its reaction to the claims of others (the node makes the publisher and the
    subscription of `execution_owner`, with QOS, and hands them over).

    Args:
        name: the node's fully qualified name (identifies its claims).
        publish: publishes a claim (std_msgs/Header) on `execution_owner`.
        on_preempted: called with the other node's name when a claim of another node, newer than ours, arrives.
    """

    def __init__(self, name: str, publish: Callable[[Header], None], on_preempted: Callable[[str], None]):
        self.name = name
        self.owner = ""
        """the node of the newest claim heard or made ('' before any)"""
        self._publish = publish
        self._on_preempted = on_preempted
        self._clock = Clock(clock_type=ClockType.SYSTEM_TIME)  # claims compare across nodes, sim time or not
        self._claimed = -math.inf  # wall time [s] of our newest claim

    def claim(self) -> None:
        """Claim the arm now (the other source disables itself when it hears this)."""
        now = self._clock.now()
        self._claimed = now.nanoseconds * 1e-9
        self.owner = self.name
        self._publish(Header(stamp=now.to_msg(), frame_id=self.name))

    def on_claim(self, msg: Header) -> None:
        """The subscription's callback: a newer claim of another node preempts this one."""
        stamp = msg.stamp.sec + msg.stamp.nanosec * 1e-9
        if msg.frame_id == self.name or stamp <= self._claimed:
            return  # ours, or older than ours
        self.owner = msg.frame_id
        self._on_preempted(msg.frame_id)

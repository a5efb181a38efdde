"""Cross-process ROS 2 smoke test: one process publishes a JointState, another decodes it.

Checks that DDS discovery, the RMW and the message adapters work end to end between two Python
processes on a random ROS domain.
"""

from __future__ import annotations

import json
import os
import random
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

REPO = Path(__file__).resolve().parents[1]
TIMEOUT_S = 30.0
TOPIC = "smoke/joint_states"

PUBLISHER = """
import json, sys, time
import numpy as np
import rclpy
from rclpy.executors import ExternalShutdownException
from sensor_msgs.msg import JointState
from msg_adapters import q_to_joint_state

q, dq = (np.array(v) for v in json.loads(sys.argv[1]))
rclpy.init()
node = rclpy.create_node("smoke_publisher")
pub = node.create_publisher(JointState, sys.argv[2], 10)
node.create_timer(0.05, lambda: pub.publish(q_to_joint_state(q, dq, stamp=node.get_clock().now().to_msg())))
end = time.monotonic() + float(sys.argv[3])  # never outlive the test, even if it is not killed
try:
    while rclpy.ok() and time.monotonic() < end:
        rclpy.spin_once(node, timeout_sec=0.1)
except (KeyboardInterrupt, ExternalShutdownException):
    pass
"""

RECEIVER = """
import json, sys, time
import rclpy
from sensor_msgs.msg import JointState
from msg_adapters import joint_state_to_q

rclpy.init()
node = rclpy.create_node("smoke_receiver")
got = []
node.create_subscription(JointState, sys.argv[1], got.append, 10)
end = time.monotonic() + float(sys.argv[2])
while not got and time.monotonic() < end:
    rclpy.spin_once(node, timeout_sec=0.1)
if not got:
    print("no JointState received", file=sys.stderr)
    sys.exit(1)
q, dq = joint_state_to_q(got[0])
print(json.dumps({"q": q.tolist(), "dq": None if dq is None else dq.tolist(), "names": list(got[0].name)}))
"""


def ros_env(domain_id: int) -> dict[str, str]:
    """The environment for a child ROS process on `domain_id`, able to import this checkout."""
    env = dict(os.environ)
    env["ROS_DOMAIN_ID"] = str(domain_id)
    env["PYTHONPATH"] = os.pathsep.join([str(REPO), *filter(None, [env.get("PYTHONPATH")])])
    env["PYTHONUNBUFFERED"] = "1"
    return env


def stop(proc: subprocess.Popen) -> None:
    """Terminate a child process (kill it if it does not exit within 5 s) and close its pipes."""
    if proc.poll() is None:
        proc.terminate()
    try:
        proc.communicate(timeout=5)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.communicate(timeout=5)


@pytest.mark.ros
@pytest.mark.timeout(90)
def test_joint_state_crosses_processes():
    domain_id = random.SystemRandom().randint(1, 100)
    rng = np.random.default_rng(7)
    q, dq = rng.uniform(-2.0, 2.0, size=7), rng.normal(size=7)
    env = ros_env(domain_id)
    payload = json.dumps([q.tolist(), dq.tolist()])
    procs = []
    try:
        publisher = subprocess.Popen(
            [sys.executable, "-c", PUBLISHER, payload, TOPIC, str(TIMEOUT_S + 10)],
            cwd=REPO,
            env=env,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )
        procs.append(publisher)
        receiver = subprocess.Popen(
            [sys.executable, "-c", RECEIVER, TOPIC, str(TIMEOUT_S)],
            cwd=REPO,
            env=env,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )
        procs.append(receiver)
        out, err = receiver.communicate(timeout=TIMEOUT_S + 10)
        assert receiver.returncode == 0, f"receiver failed (domain {domain_id}):\n{err}"
        assert publisher.poll() is None, f"publisher died:\n{publisher.communicate()[1]}"
        result = json.loads(out.strip().splitlines()[-1])
        assert result["names"] == [f"panda_joint{i}" for i in range(1, 8)]
        np.testing.assert_array_equal(result["q"], q)
        np.testing.assert_array_equal(result["dq"], dq)
    finally:
        for proc in procs:
            stop(proc)

"""The robot_info node, run as a process the way users start it, observed from an in-test ROS context."""

from __future__ import annotations

import os
import random
import signal
import subprocess
import sys
import time
import xml.etree.ElementTree as ET
from collections.abc import Callable, Iterator
from pathlib import Path

import numpy as np
import pytest
import rclpy
from rclpy.context import Context
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import JointState
from std_msgs.msg import String

from latent_planner_ros.robot.limits import JOINT_NAMES, Q_READY
from msg_adapters import joint_state_to_q

REPO = Path(__file__).resolve().parents[2]
TIMEOUT_S = 30.0
LATCHED = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL, reliability=ReliabilityPolicy.RELIABLE)

pytestmark = [pytest.mark.ros, pytest.mark.timeout(120)]


class Probe:
    """A node in its own rclpy context on `domain_id` that records what it receives."""

    def __init__(self, domain_id: int):
        self.context = Context()
        rclpy.init(context=self.context, domain_id=domain_id)
        self.node = Node("robot_info_probe", context=self.context)
        self.executor = SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.node)
        self.descriptions: list[String] = []
        self.joint_states: list[JointState] = []

    def subscribe_description(self) -> None:
        self.node.create_subscription(String, "robot_description", self.descriptions.append, LATCHED)

    def subscribe_joint_states(self) -> None:
        self.node.create_subscription(JointState, "joint_states", self.joint_states.append, 10)

    def spin_until(self, done: Callable[[], bool], timeout_s: float = TIMEOUT_S) -> bool:
        end = time.monotonic() + timeout_s
        while not done() and time.monotonic() < end:
            self.executor.spin_once(timeout_sec=0.05)
        return done()

    def close(self) -> None:
        self.executor.shutdown()
        self.node.destroy_node()
        rclpy.try_shutdown(context=self.context)


@pytest.fixture
def domain_id() -> int:
    return random.SystemRandom().randint(1, 100)


@pytest.fixture
def probe(domain_id) -> Iterator[Probe]:
    p = Probe(domain_id)
    try:
        yield p
    finally:
        p.close()


def start_robot_info(domain_id: int, *args: str) -> subprocess.Popen:
    env = dict(os.environ, ROS_DOMAIN_ID=str(domain_id), PYTHONUNBUFFERED="1")
    env["PYTHONPATH"] = os.pathsep.join([str(REPO), *filter(None, [os.environ.get("PYTHONPATH")])])
    return subprocess.Popen(
        [sys.executable, "-m", "latent_planner_ros", "run", "robot_info", *args],
        cwd=REPO,
        env=env,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )


def finish(proc: subprocess.Popen, sig: int | None = None, timeout_s: float = TIMEOUT_S) -> tuple[int, str]:
    """Optionally signal the process, wait for it (killing it on timeout), return (exit code, output)."""
    try:
        if sig is not None and proc.poll() is None:
            proc.send_signal(sig)
        out, err = proc.communicate(timeout=timeout_s)
    except subprocess.TimeoutExpired:
        proc.kill()
        out, err = proc.communicate(timeout=5)
        pytest.fail(f"robot_info did not exit within {timeout_s} s:\n{out}\n{err}")
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.communicate(timeout=5)
    return proc.returncode, out + err


def assert_ready_pose(msg: JointState, names=JOINT_NAMES) -> None:
    assert list(msg.name) == list(names)
    q, _ = joint_state_to_q(msg, names)
    np.testing.assert_array_equal(q, Q_READY)


def assert_panda_urdf(xml: str, prefix: str = "panda_") -> None:
    """robot_description is the URDF: a <robot> with 7 revolute arm joints named <prefix>joint1..7."""
    root = ET.fromstring(xml)
    assert root.tag == "robot"
    joints = {j.get("name"): j.get("type") for j in root.iter("joint")}
    assert all(joints[f"{prefix}joint{i}"] == "revolute" for i in range(1, 8)), joints
    assert f"{prefix}link0" in {link.get("name") for link in root.iter("link")}
    assert {p.get("link") for p in root.iter("parent")} <= {link.get("name") for link in root.iter("link")}


def test_once_publishes_description_and_ready_pose(domain_id, probe):
    probe.subscribe_description()
    probe.subscribe_joint_states()
    # Discovery between processes can take a few seconds under load: allow more than the default 2 s.
    proc = start_robot_info(domain_id, "--once", "--wait", "15")
    try:
        received = probe.spin_until(lambda: bool(probe.descriptions and probe.joint_states))
    finally:
        code, output = finish(proc)
    assert received, f"nothing received on domain {domain_id}; node output:\n{output}"
    assert code == 0, output
    assert "Traceback" not in output
    assert_panda_urdf(probe.descriptions[0].data)
    assert_ready_pose(probe.joint_states[0])


def test_joint_prefix_renames_the_urdf_and_the_joint_states(domain_id, probe):
    probe.subscribe_description()
    probe.subscribe_joint_states()
    proc = start_robot_info(domain_id, "--once", "--wait", "15", "--ros-args", "-p", "joint_prefix:=fr3_")
    try:
        received = probe.spin_until(lambda: bool(probe.descriptions and probe.joint_states))
    finally:
        code, output = finish(proc)
    assert received and code == 0, output
    assert_panda_urdf(probe.descriptions[0].data, "fr3_")
    assert "panda_" not in probe.descriptions[0].data.replace("panda_description", "")
    assert_ready_pose(probe.joint_states[0], tuple(f"fr3_joint{i}" for i in range(1, 8)))


def test_spins_at_10hz_latches_description_and_stops_on_ctrl_c(domain_id, probe):
    probe.subscribe_joint_states()
    proc = start_robot_info(domain_id)
    try:
        assert probe.spin_until(lambda: len(probe.joint_states) >= 6), "no joint_states received"
        # Subscribe late: the description was published long ago and must still arrive (transient local).
        probe.subscribe_description()
        assert probe.spin_until(lambda: bool(probe.descriptions)), "robot_description not latched"
    finally:
        code, output = finish(proc, signal.SIGINT)
    assert code == 0, output
    assert "Traceback" not in output and "KeyboardInterrupt" not in output
    assert "panda_joint7" in probe.descriptions[0].data
    for msg in probe.joint_states:
        assert_ready_pose(msg)
    stamps = np.array([m.header.stamp.sec + 1e-9 * m.header.stamp.nanosec for m in probe.joint_states[1:]])
    assert 0.05 < float(np.median(np.diff(stamps))) < 0.2  # 10 Hz


def _run_cli(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "latent_planner_ros", "run", "robot_info", *args],
        cwd=REPO,
        capture_output=True,
        text=True,
        timeout=TIMEOUT_S,
    )


def test_help_lists_options():
    proc = _run_cli("--help")
    assert proc.returncode == 0, proc.stderr
    assert "--once" in proc.stdout and "--wait" in proc.stdout


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--bogus"], "unrecognized arguments: --bogus"),
        (["--once", "--ros-args", "-r", "joint_states:=js", "--wait", "1"], "unknown ROS arguments"),
        (["--once", "--ros-args", "-r", "a:=b:=c"], "Couldn't parse remap rule"),
    ],
)
def test_bad_arguments_exit_2_without_traceback(args, message):
    proc = _run_cli(*args)
    assert proc.returncode == 2, proc.stderr
    assert message in proc.stderr and "Traceback" not in proc.stderr

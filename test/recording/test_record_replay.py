"""A run recorded with ``launch --record`` and read back with rosbags (an independent reader), then replayed."""

from __future__ import annotations

import os
import random
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest
import rclpy
import yaml
from rclpy.context import Context
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.signals import SignalHandlerOptions
from rosbags.highlevel import AnyReader
from rosbags.typesys import Stores, get_typestore
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import JointState

REPO = Path(__file__).resolve().parents[2]
SIM_TOPICS = {
    "/clock": "rosgraph_msgs/msg/Clock",
    "/joint_states": "sensor_msgs/msg/JointState",
    "/camera/points": "sensor_msgs/msg/PointCloud2",
    "/camera/pose": "geometry_msgs/msg/PoseStamped",
    "/target_pose": "geometry_msgs/msg/PoseStamped",
    "/sim/in_collision": "std_msgs/msg/Bool",
    "/sim/min_distance": "std_msgs/msg/Float64",
}
"""what the sim publishes (its subscriptions joint_command and joint_trajectory have no publisher)"""


def _env() -> dict:
    env = dict(os.environ, PYTHONUNBUFFERED="1")
    env["PYTHONPATH"] = os.pathsep.join([str(REPO), *filter(None, [os.environ.get("PYTHONPATH")])])
    return env


@pytest.fixture(scope="module")
def recorded(tmp_path_factory) -> tuple[Path, str]:
    """A bag of 4 s of the sim (real time), recorded by the launcher; (bag directory, launcher output)."""
    bag = tmp_path_factory.mktemp("record") / "run"
    domain = random.SystemRandom().randint(1, 100)
    cmd = [sys.executable, "-m", "latent_planner_ros", "launch", "--nodes", "sim", "--headless", "--duration", "4"]
    cmd += ["--domain-id", str(domain), "--record", str(bag)]
    proc = subprocess.run(cmd, cwd=REPO, env=_env(), capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr[-3000:]
    return bag, proc.stderr


def _read(bag: Path) -> dict[str, list]:
    """{topic: [(log time [ns], message)]} decoded with the definitions stored in the bag (rosbags registers
    them; an empty type store, so nothing comes from rosbags' own copy of the types)."""
    out: dict[str, list] = {}
    with AnyReader([bag], default_typestore=get_typestore(Stores.EMPTY)) as reader:
        for connection in reader.connections:
            assert connection.msgdef.data, f"{connection.topic} has no message definition"
        for connection, log_ns, raw in reader.messages():
            out.setdefault(connection.topic, []).append((log_ns, reader.deserialize(raw, connection.msgtype)))
        counts = {c.topic: c.msgcount for c in reader.connections}
        types = {c.topic: c.msgtype for c in reader.connections}
    assert {t: len(v) for t, v in out.items()} == {t: n for t, n in counts.items() if n}
    return out, types


@pytest.mark.ros
@pytest.mark.slow
@pytest.mark.timeout(150)
def test_a_recorded_run_has_every_topic_its_counts_and_ordered_stamps(recorded):
    bag, log = recorded
    assert f"bag {bag}:" in log
    messages, types = _read(bag)
    for topic, type_name in SIM_TOPICS.items():
        assert types.get(topic) == type_name, topic
        assert messages.get(topic), f"no message on {topic}"
    joints = messages["/joint_states"]
    span_s = (joints[-1][0] - joints[0][0]) * 1e-9
    assert span_s > 3.0
    # the sim publishes joint_states at 100 Hz of simulated time, at real time here
    assert 50 * span_s < len(joints) < 130 * span_s
    assert len(messages["/camera/points"]) > 3 * span_s  # camera at 10-15 Hz
    stamps = np.array([m.header.stamp.sec + m.header.stamp.nanosec * 1e-9 for _, m in joints])
    assert np.all(np.diff(stamps) > 0), "joint_states stamps are not increasing"
    assert np.all(np.diff([t for t, _ in joints]) >= 0), "log times are not ordered"
    clock = np.array([m.clock.sec + m.clock.nanosec * 1e-9 for _, m in messages["/clock"]])
    assert np.all(np.diff(clock) >= 0) and clock[0] <= stamps[-1] <= clock[-1] + 0.05
    assert list(joints[-1][1].name[:7]) == [f"panda_joint{i}" for i in range(1, 8)]
    cloud = messages["/camera/points"][-1][1]
    assert cloud.width * cloud.height > 100 and cloud.header.frame_id == "world"
    info = yaml.safe_load((bag / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    assert info["storage_identifier"] == "mcap" and info["message_count"] == sum(len(v) for v in messages.values())


def _schemas(bag: Path) -> dict[str, tuple[str, str]]:
    from mcap.reader import make_reader

    with open(next(bag.glob("*.mcap")), "rb") as f:
        reader = make_reader(f)
        header = reader.get_header()
        summary = reader.get_summary()
    assert header.profile == "ros2"
    channels = {c.topic: c for c in summary.channels.values()}
    assert {c.message_encoding for c in channels.values()} == {"cdr"}
    return {t: (summary.schemas[c.schema_id].name, summary.schemas[c.schema_id].encoding) for t, c in channels.items()}


@pytest.mark.ros
@pytest.mark.slow
def test_the_mcap_follows_rosbag2_conventions_and_decodes_with_mcap_ros2(recorded):
    """Profile ros2, ros2msg schemas, cdr channels; mcap-ros2-support's decoder reads every message."""
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory

    bag, _ = recorded
    schemas = _schemas(bag)
    assert all(enc == "ros2msg" for _, enc in schemas.values())
    assert schemas["/joint_states"][0] == "sensor_msgs/msg/JointState"
    with open(next(bag.glob("*.mcap")), "rb") as f:
        decoded = list(make_reader(f, decoder_factories=[DecoderFactory()]).iter_decoded_messages())
    assert decoded and all(msg is not None for *_, msg in decoded)


class _Listener(Node):
    def __init__(self, context):
        super().__init__("replay_listener", context=context, start_parameter_services=False)
        self.stamps: list[tuple[float, float]] = []  # (receipt [s], header stamp [s])
        self.clock = 0
        self.create_subscription(JointState, "joint_states", self._on, 100)
        self.create_subscription(Clock, "/clock", self._on_clock, 100)

    def _on_clock(self, msg: Clock) -> None:
        self.clock += 1

    def _on(self, msg: JointState) -> None:
        self.stamps.append((time.monotonic(), msg.header.stamp.sec + msg.header.stamp.nanosec * 1e-9))


@pytest.mark.ros
@pytest.mark.slow
@pytest.mark.timeout(120)
def test_replay_publishes_the_recorded_messages_with_their_timing(recorded):
    bag, _ = recorded
    messages, _ = _read(bag)
    recorded_joints = messages["/joint_states"]
    n_clock = len(messages["/clock"])
    domain = random.SystemRandom().randint(101, 200)
    context = Context()
    rclpy.init(context=context, domain_id=domain, signal_handler_options=SignalHandlerOptions.NO)
    node = _Listener(context)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)
    stop = threading.Event()

    def spin():
        while not stop.is_set():
            executor.spin_once(timeout_sec=0.05)

    thread = threading.Thread(target=spin, daemon=True)
    thread.start()
    try:
        cmd = [sys.executable, "-m", "latent_planner_ros", "replay", str(bag), "--domain-id", str(domain)]
        cmd += ["--topics", "joint_states,clock", "--delay", "0", "--wait-subscribers", "20"]
        proc = subprocess.run(cmd, cwd=REPO, env=_env(), capture_output=True, text=True, timeout=60)
        assert proc.returncode == 0, proc.stderr[-3000:]
        time.sleep(0.5)
    finally:
        stop.set()
        thread.join(timeout=2.0)
        executor.shutdown(timeout_sec=1.0)
        node.destroy_node()
        rclpy.try_shutdown(context=context)
    assert f"done: {len(recorded_joints) + n_clock} messages published" in proc.stdout
    got = node.stamps
    assert node.clock >= 0.98 * n_clock
    assert len(got) >= 0.98 * len(recorded_joints), (len(got), len(recorded_joints))
    expected = [m.header.stamp.sec + m.header.stamp.nanosec * 1e-9 for _, m in recorded_joints]
    assert [s for _, s in got] == expected[-len(got) :]  # the same messages, in order
    recorded_span = (recorded_joints[-1][0] - recorded_joints[0][0]) * 1e-9
    replay_span = got[-1][0] - got[0][0]
    assert replay_span == pytest.approx(recorded_span, rel=0.15)


@pytest.mark.ros
@pytest.mark.slow
@pytest.mark.timeout(120)
def test_replay_into_the_view_shows_the_recorded_arm_and_cloud(recorded):
    """``replay BAG --view``: the page shows the recorded robot and cloud (Chromium, as in test/view)."""
    from test.view.browser import CHROMEDRIVER, CHROMIUM, chromium, free_port, scene_nodes, wait_for, wait_http

    if not (CHROMIUM.exists() and CHROMEDRIVER.exists()):
        pytest.skip("Debian chromium and chromium-driver (make setup)")
    bag, _ = recorded
    port, domain = free_port(), random.SystemRandom().randint(101, 200)
    cmd = [sys.executable, "-m", "latent_planner_ros", "replay", str(bag), "--view", "--port", str(port)]
    cmd += ["--domain-id", str(domain)]
    proc = subprocess.Popen(cmd, cwd=REPO, env=_env(), stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    driver = None
    try:
        wait_http(f"http://localhost:{port}", proc)
        driver = chromium()
        driver.get(f"http://localhost:{port}")

        def shown():
            nodes = scene_nodes(driver) or {}
            cloud, hand = nodes.get("/clouds/camera/points"), nodes.get("/robot/panda_hand_0")
            return cloud is not None and cloud["points"] > 100 and hand is not None and hand["visible"]

        wait_for(shown, 60.0, "the replayed robot and cloud in the page")
    finally:
        if driver is not None:
            driver.quit()
        proc.send_signal(signal.SIGINT)
        try:
            output, _ = proc.communicate(timeout=15)
        except subprocess.TimeoutExpired:
            proc.kill()
            output, _ = proc.communicate()
    assert proc.returncode == 0, output[-2000:]
    assert f"[replay] {bag}:" in output  # interrupted while playing or after: either ends cleanly

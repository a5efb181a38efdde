"""The view as a user sees it: a headless Chromium opens the page served by ``python -m latent_planner_ros view``,
the robot (at the published joint state) and a 30k-point cloud appear, a goal typed into the page arrives on
goal_pose, and the "Planner enabled" box calls the planner's enable service.

The publishers are fake ones in this process (joint_states, camera/points, planner/status, planner/enable): the
view is tested against what it reads, not the suite's behaviour.
"""

from __future__ import annotations

import os
import random
import subprocess
import sys
import threading
import time
import urllib.request
from pathlib import Path

import numpy as np
import pytest

from test.view.browser import CHROMEDRIVER, CHROMIUM, chromium, dismiss_notifications, scene_nodes

REPO = Path(__file__).resolve().parents[2]
Q = np.array([0.3, -0.4, 0.1, -2.0, 0.05, 1.7, 0.6])
N_POINTS = 30_000

pytestmark = pytest.mark.skipif(
    not (CHROMIUM.exists() and CHROMEDRIVER.exists()), reason="Debian chromium and chromium-driver (make setup)"
)


class FakeSuite:
    """joint_states (50 Hz), camera/points (10 Hz, N_POINTS), planner/status (disabled, p_collision 0.7), a
    planner/enable service and a goal_pose subscription, spun in this process."""

    def __init__(self, domain_id: int, cloud_hz: float = 10.0):
        import rclpy
        from diagnostic_msgs.msg import DiagnosticArray
        from geometry_msgs.msg import PoseStamped
        from rclpy.context import Context
        from rclpy.executors import SingleThreadedExecutor
        from rclpy.node import Node
        from rclpy.signals import SignalHandlerOptions
        from sensor_msgs.msg import JointState, PointCloud2
        from std_srvs.srv import SetBool

        from msg_adapters import q_to_joint_state, status_array, xyz_to_cloud

        self.context = Context()
        rclpy.init(context=self.context, domain_id=domain_id, signal_handler_options=SignalHandlerOptions.NO)
        node = self.node = Node("fake_suite", context=self.context, start_parameter_services=False)
        rng = np.random.default_rng(0)
        points = rng.uniform([0.3, -0.4, 0.0], [0.9, 0.4, 0.3], size=(N_POINTS, 3)).astype(np.float32)
        self.goals: list = []
        self.enable_requests: list[bool] = []
        pub_joints = node.create_publisher(JointState, "joint_states", 10)
        pub_cloud = node.create_publisher(PointCloud2, "camera/points", 2)
        pub_status = node.create_publisher(DiagnosticArray, "planner/status", 10)
        node.create_subscription(PoseStamped, "goal_pose", self.goals.append, 10)

        def enable(request, response):
            self.enable_requests.append(bool(request.data))
            response.success = True
            return response

        node.create_service(SetBool, "planner/enable", enable)
        self.q = Q.copy()
        node.create_timer(
            0.02, lambda: pub_joints.publish(q_to_joint_state(self.q, stamp=node.get_clock().now().to_msg()))
        )
        node.create_timer(
            1.0 / cloud_hz, lambda: pub_cloud.publish(xyz_to_cloud(points, "world", node.get_clock().now().to_msg()))
        )
        status = {"state": "disabled", "p_collision": 0.7, "tick_ms": 3.2, "last_error": ""}
        node.create_timer(0.2, lambda: pub_status.publish(status_array("planner", 0, "disabled", status)))
        self.executor = SingleThreadedExecutor(context=self.context)
        self.executor.add_node(node)
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._spin, daemon=True)
        self._thread.start()

    def _spin(self) -> None:
        while not self._stop.is_set():
            self.executor.spin_once(timeout_sec=0.05)

    def close(self) -> None:
        import rclpy

        self._stop.set()
        self._thread.join(timeout=2.0)
        self.executor.shutdown(timeout_sec=1.0)
        self.node.destroy_node()
        rclpy.try_shutdown(context=self.context)


def _free_port() -> int:
    import socket

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _wait_http(url: str, proc: subprocess.Popen, timeout_s: float = 60.0) -> None:
    end = time.monotonic() + timeout_s
    while time.monotonic() < end:
        assert proc.poll() is None, proc.communicate()[0][-3000:]
        try:
            urllib.request.urlopen(url, timeout=1.0).read(100)
            return
        except OSError:
            time.sleep(0.3)
    raise TimeoutError(f"{url} did not answer in {timeout_s:g} s")


def _wait(predicate, timeout_s: float, what: str):
    end = time.monotonic() + timeout_s
    while time.monotonic() < end:
        value = predicate()
        if value:
            return value
        time.sleep(0.25)
    raise AssertionError(f"timed out after {timeout_s:g} s waiting for {what}")


def _set_field(driver, label: str, value: float) -> None:
    from selenium.webdriver.common.by import By
    from selenium.webdriver.common.keys import Keys

    field = driver.find_element(
        By.ID, driver.find_element(By.XPATH, f"//label[normalize-space()='{label}']").get_attribute("for")
    )
    field.send_keys(Keys.CONTROL, "a")
    field.send_keys(f"{abs(value)}")
    if value < 0:  # a lone "-" is not a number the field takes: the sign goes in front of the digits
        field.send_keys(Keys.HOME, "-")
    field.send_keys(Keys.TAB)


@pytest.fixture(scope="module")
def view_page(tmp_path_factory):
    """(driver, fake suite, url): the view process, its page in Chromium and the fake publishers."""
    domain = random.SystemRandom().randint(1, 100)
    port = _free_port()
    suite = FakeSuite(domain)
    env = dict(os.environ, ROS_DOMAIN_ID=str(domain), PYTHONUNBUFFERED="1")
    env["PYTHONPATH"] = os.pathsep.join([str(REPO), *filter(None, [os.environ.get("PYTHONPATH")])])
    cmd = [sys.executable, "-m", "latent_planner_ros", "view", "--port", str(port)]
    proc = subprocess.Popen(cmd, cwd=REPO, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    driver = None
    try:
        url = f"http://localhost:{port}"
        _wait_http(url, proc)
        driver = chromium()
        driver.get(url)
        yield driver, suite, proc
    finally:
        if driver is not None:
            driver.quit()
        proc.terminate()
        try:
            proc.wait(timeout=10)
        except subprocess.TimeoutExpired:
            proc.kill()
        suite.close()


@pytest.mark.ros
@pytest.mark.slow
@pytest.mark.timeout(180)
def test_the_page_shows_the_robot_at_the_joint_state_and_the_cloud(view_page, tmp_path):
    from latent_planner_ros.robot.panda import load_panda

    driver, _, _ = view_page

    def ready():
        nodes = scene_nodes(driver) or {}
        cloud, link7 = nodes.get("/clouds/camera/points"), nodes.get("/robot/panda_link7_0")
        return nodes if cloud and cloud["points"] == N_POINTS and link7 and link7["visible"] else None

    nodes = _wait(ready, 60.0, "the robot and a 30k-point cloud in the page")
    # the hand mesh sits where the arm's kinematics put panda_hand for the published joint state
    hand = load_panda().fk(Q, "panda_hand").translation
    assert np.allclose(nodes["/robot/panda_hand_0"]["position"], hand, atol=1e-3)
    assert all(nodes[f"/robot/panda_link{i}_0"]["visible"] for i in range(8))
    assert "/goal" in nodes and "/table" in nodes
    status = _wait(lambda: "disabled" in driver.page_source and driver.page_source, 10.0, "the planner status")
    assert "p_collision" in status and "0.7" in status
    dismiss_notifications(driver)
    driver.save_screenshot(str(tmp_path / "view.png"))
    assert (tmp_path / "view.png").stat().st_size > 10_000


@pytest.mark.ros
@pytest.mark.slow
@pytest.mark.timeout(120)
def test_a_goal_typed_into_the_page_arrives_on_goal_pose(view_page):
    from selenium.webdriver.common.by import By

    driver, suite, _ = view_page
    _wait(lambda: driver.find_elements(By.XPATH, "//label[normalize-space()='goal x']"), 30.0, "the goal fields")
    for label, value in (("goal x", 0.52), ("goal y", -0.21), ("goal z", 0.33)):
        _set_field(driver, label, value)
    suite.goals.clear()
    driver.find_element(By.XPATH, "//button[normalize-space()='Send goal']").click()
    goal = _wait(lambda: suite.goals[-1] if suite.goals else None, 10.0, "goal_pose")
    p = goal.pose.position
    assert goal.header.frame_id == "world"
    assert (p.x, p.y, p.z) == pytest.approx((0.52, -0.21, 0.33), abs=1e-6)
    q = goal.pose.orientation
    assert np.linalg.norm([q.x, q.y, q.z, q.w]) == pytest.approx(1.0, abs=1e-6)

    # the gizmo moved with the fields
    def gizmo_at_goal():
        position = (scene_nodes(driver) or {}).get("/goal", {}).get("position")
        return position is not None and np.allclose(position, [0.52, -0.21, 0.33], atol=1e-4)

    _wait(gizmo_at_goal, 5.0, "the gizmo at the goal")


@pytest.mark.ros
@pytest.mark.slow
@pytest.mark.timeout(60)
def test_the_enable_box_calls_the_planners_enable_service(view_page):
    from selenium.webdriver.common.by import By

    driver, suite, _ = view_page
    label = driver.find_element(By.XPATH, "//label[normalize-space()='Planner enabled']")
    box = driver.find_element(By.ID, label.get_attribute("for"))
    _wait(lambda: not box.is_selected(), 10.0, "the box to show the planner disabled (from its status)")
    suite.enable_requests.clear()
    driver.execute_script("arguments[0].click();", box)
    assert _wait(lambda: suite.enable_requests, 10.0, "a planner/enable request") == [True]


@pytest.mark.ros
@pytest.mark.slow
@pytest.mark.timeout(60)
def test_pause_freezes_the_view_until_it_is_released(view_page):
    from selenium.webdriver.common.by import By

    from latent_planner_ros.robot.panda import load_panda

    driver, suite, _ = view_page
    label = driver.find_element(By.XPATH, "//label[normalize-space()='Pause']")
    box = driver.find_element(By.ID, label.get_attribute("for"))

    def hand():
        return np.array((scene_nodes(driver) or {})["/robot/panda_hand_0"]["position"])

    before = hand()
    driver.execute_script("arguments[0].click();", box)
    time.sleep(0.5)
    moved = Q + np.array([0.4, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0])
    suite.q = moved
    time.sleep(1.5)
    assert np.allclose(hand(), before, atol=1e-6), "the robot moved while paused"
    driver.execute_script("arguments[0].click();", box)
    target = load_panda().fk(moved, "panda_hand").translation
    _wait(lambda: np.allclose(hand(), target, atol=1e-3), 10.0, "the robot at the new joint state after the pause")
    suite.q = Q.copy()

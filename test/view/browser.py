"""A headless Chromium (Debian's chromium and chromium-driver) driven by Selenium, and a fake suite publishing what
the view reads, for the view's tests and measurements.

Also a script: ``.venv/bin/python test/view/browser.py URL OUT.png [WAIT_S]`` saves a screenshot of a page
(docs/view.png is made this way from a running ``launch --view``).
"""

from __future__ import annotations

import subprocess
import sys
import threading
import time
import urllib.request
from pathlib import Path

import numpy as np

CHROMIUM = Path("/usr/bin/chromium")
CHROMEDRIVER = Path("/usr/bin/chromedriver")
Q = np.array([0.3, -0.4, 0.1, -2.0, 0.05, 1.7, 0.6])
"""the fake suite's joint state [rad]"""
N_POINTS = 30_000
"""points of the fake suite's cloud"""


def chromium(width: int = 1280, height: int = 800):
    """A headless Chromium WebDriver (WebGL through SwiftShader, as on a machine without a GPU)."""
    from selenium import webdriver
    from selenium.webdriver.chrome.options import Options
    from selenium.webdriver.chrome.service import Service

    options = Options()
    options.binary_location = str(CHROMIUM)
    for arg in ("--headless=new", "--no-sandbox", "--disable-dev-shm-usage", f"--window-size={width},{height}"):
        options.add_argument(arg)
    options.add_argument("--enable-unsafe-swiftshader")
    return webdriver.Chrome(service=Service(str(CHROMEDRIVER)), options=options)


def scene_nodes(driver) -> dict:
    """{scene node name: {visible, points (for point clouds), position (posed nodes)}} as the page holds them."""
    return driver.execute_script(
        """
        const tree = window.__viserSceneTree, mutable = window.__viserMutable;
        if (!tree || !mutable) return null;
        const out = {};
        for (const [name, node] of Object.entries(tree.getState())) {
            const msg = node.message || {}, props = msg.props || {};
            const pose = mutable.nodePoseData[name];
            out[name] = {
                type: msg.type || null,
                visible: node.effectiveVisibility !== false,
                points: props.points ? props.points.byteLength / (props.precision === "float16" ? 6 : 12) : null,
                position: pose ? pose.position : null,
                color: props.color ? Array.from(props.color) : null,
            };
        }
        return out;
        """
    )


SCREEN_POINTS_JS = """
const m = window.__viserMutable, ref = m.nodeRefFromName[arguments[0]];
const obj = ref.current || ref;
obj.updateWorldMatrix(true, false);
const rect = m.canvas.getBoundingClientRect();
return arguments[1].map(([x, y, z]) => {
    const v = m.camera.position.clone().set(x, y, z);
    obj.localToWorld(v);
    v.project(m.camera);
    return [(v.x + 1) / 2 * rect.width - rect.width / 2, (1 - v.y) / 2 * rect.height - rect.height / 2];
});
"""


def screen_offsets(driver, node: str, local_points) -> list[tuple[float, float]]:
    """Where points given in a scene node's own frame (its three.js object) appear on the canvas: offsets [px]
    from the canvas centre (as Selenium's move_to_element_with_offset takes them)."""
    return [
        tuple(p) for p in driver.execute_script(SCREEN_POINTS_JS, node, [list(map(float, q)) for q in local_points])
    ]


def drag(driver, start: tuple[float, float], end: tuple[float, float], steps: int = 10) -> None:
    """Press the left button at `start` on the canvas, move to `end` in steps, release (offsets from its centre)."""
    from selenium.webdriver.common.action_chains import ActionChains

    canvas = driver.execute_script("return window.__viserMutable.canvas")
    chain = ActionChains(driver).move_to_element_with_offset(canvas, int(start[0]), int(start[1])).click_and_hold()
    for _ in range(steps):
        chain.move_by_offset(int((end[0] - start[0]) / steps), int((end[1] - start[1]) / steps))
    chain.release().perform()


def dismiss_notifications(driver) -> None:
    """Close viser's toasts (e.g. "Software WebGL rendering detected") so they do not cover a screenshot."""
    driver.execute_script(
        "document.querySelectorAll('.mantine-Notification-closeButton, .mantine-Notifications-root button')"
        ".forEach(b => b.click());"
    )


class FakeSuite:
    """joint_states (50 Hz), camera/points (10 Hz, N_POINTS), planner/status (disabled, p_collision 0.7, the hand
    at 0.9 and link1 at 0 in p_collision_links), a planner/enable service and a goal_pose subscription, spun in
    this process."""

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

        from msg_adapters import q_to_joint_state, status_array

        self.context = Context()
        rclpy.init(context=self.context, domain_id=domain_id, signal_handler_options=SignalHandlerOptions.NO)
        node = self.node = Node("fake_suite", context=self.context, start_parameter_services=False)
        rng = np.random.default_rng(0)
        points = rng.uniform([0.3, -0.4, 0.0], [0.9, 0.4, 0.3], size=(N_POINTS, 3)).astype(np.float32)
        self._points, self._published = points, 0
        self.clouds_on = True  # off: no more clouds (the page has less to draw)
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
            1.0 / cloud_hz,
            lambda: self._publish_cloud(pub_cloud, node.get_clock().now().to_msg()),
        )
        status = {"state": "disabled", "p_collision": 0.7, "tick_ms": 3.2, "last_error": ""}
        status["p_collision_links"] = "panda_link1=0.000 panda_hand=0.900"
        node.create_timer(0.2, lambda: pub_status.publish(status_array("planner", 0, "disabled", status)))
        self.executor = SingleThreadedExecutor(context=self.context)
        self.executor.add_node(node)
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._spin, daemon=True)
        self._thread.start()

    def _publish_cloud(self, pub, stamp) -> None:
        from msg_adapters import xyz_to_cloud

        if self.clouds_on:
            pub.publish(xyz_to_cloud(self._next_cloud(), "world", stamp))

    def _next_cloud(self) -> np.ndarray:
        """The cloud shifted by 0.1 mm more along x each time (every cloud differs, as a camera's do)."""
        self._published += 1
        shifted = self._points.copy()
        shifted[:, 0] += 1e-4 * (self._published % 100)
        return shifted

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


def free_port() -> int:
    import socket

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def wait_http(url: str, proc: subprocess.Popen, timeout_s: float = 60.0) -> None:
    end = time.monotonic() + timeout_s
    while time.monotonic() < end:
        assert proc.poll() is None, proc.communicate()[0][-3000:]
        try:
            urllib.request.urlopen(url, timeout=1.0).read(100)
            return
        except OSError:
            time.sleep(0.3)
    raise TimeoutError(f"{url} did not answer in {timeout_s:g} s")


def wait_for(predicate, timeout_s: float, what: str):
    end = time.monotonic() + timeout_s
    while time.monotonic() < end:
        value = predicate()
        if value:
            return value
        time.sleep(0.25)
    raise AssertionError(f"timed out after {timeout_s:g} s waiting for {what}")


def main(argv: list[str]) -> int:
    url, out = argv[0], Path(argv[1])
    wait_s = float(argv[2]) if len(argv) > 2 else 8.0
    driver = chromium()
    try:
        driver.get(url)
        time.sleep(wait_s)
        dismiss_notifications(driver)
        time.sleep(0.5)
        driver.save_screenshot(str(out))
    finally:
        driver.quit()
    print(out)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))

"""The view as a user sees it: a headless Chromium opens the page served by ``python -m latent_planner_ros view``,
the robot (at the published joint state) and a 30k-point cloud appear, a goal typed into the page and a drag of
the goal gizmo arrive on goal_pose, the "Planner enabled" box calls the planner's enable service, Pause freezes.

The publishers are fake ones in this process (joint_states, camera/points, planner/status, planner/enable): the
view is tested against what it reads, not the suite's behaviour.
"""

from __future__ import annotations

import os
import random
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from latent_planner_ros.view.scene import ROBOT_RGB
from test.view.browser import (
    CHROMEDRIVER,
    CHROMIUM,
    N_POINTS,
    FakeSuite,
    Q,
    chromium,
    dismiss_notifications,
    drag,
    free_port,
    scene_nodes,
    screen_offsets,
    wait_for,
    wait_http,
)

REPO = Path(__file__).resolve().parents[2]

pytestmark = pytest.mark.skipif(
    not (CHROMIUM.exists() and CHROMEDRIVER.exists()), reason="Debian chromium and chromium-driver (make setup)"
)


SET_INPUT_JS = """
const [input, text] = arguments;
const setter = Object.getOwnPropertyDescriptor(HTMLInputElement.prototype, "value").set;
input.focus();
setter.call(input, text);
input.dispatchEvent(new Event("input", { bubbles: true }));
input.blur();
"""
"""Type into a (React-controlled) input as the keyboard does: the new text, then the input event. Selenium's
send_keys waits on every key stroke, which a page drawing a few frames per second (software WebGL) makes slow."""


def _set_field(driver, label: str, value: float) -> None:
    from selenium.webdriver.common.by import By

    field_id = driver.find_element(By.XPATH, f"//label[normalize-space()='{label}']").get_attribute("for")
    driver.execute_script(SET_INPUT_JS, driver.find_element(By.ID, field_id), f"{value}")


@pytest.fixture(scope="module")
def view_page(tmp_path_factory):
    """(driver, fake suite, url): the view process, its page in Chromium and the fake publishers."""
    domain = random.SystemRandom().randint(1, 100)
    port = free_port()
    suite = FakeSuite(domain)
    env = dict(os.environ, ROS_DOMAIN_ID=str(domain), PYTHONUNBUFFERED="1")
    env["PYTHONPATH"] = os.pathsep.join([str(REPO), *filter(None, [os.environ.get("PYTHONPATH")])])
    cmd = [sys.executable, "-m", "latent_planner_ros", "view", "--port", str(port)]
    proc = subprocess.Popen(cmd, cwd=REPO, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    driver = None
    try:
        url = f"http://localhost:{port}"
        wait_http(url, proc)
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

    nodes = wait_for(ready, 60.0, "the robot and a 30k-point cloud in the page")
    # the hand mesh sits where the arm's kinematics put panda_hand for the published joint state
    hand = load_panda().fk(Q, "panda_hand").translation
    assert np.allclose(nodes["/robot/panda_hand_0"]["position"], hand, atol=1e-3)
    assert all(nodes[f"/robot/panda_link{i}_0"]["visible"] for i in range(8))
    assert "/goal" in nodes and "/table" in nodes

    # links coloured by the status's per-link probabilities: the hand (0.9) red, link1 (0) grey
    def colours():
        now = scene_nodes(driver) or {}
        hand, link1 = now["/robot/panda_hand_0"]["color"], now["/robot/panda_link1_0"]["color"]
        return (hand, link1) if hand and hand[0] > hand[1] + 100 and link1 == list(ROBOT_RGB) else None

    wait_for(colours, 10.0, "the hand red and link1 grey")
    status = wait_for(lambda: "disabled" in driver.page_source and driver.page_source, 10.0, "the planner status")
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
    suite.clouds_on = False  # the cloud was checked: less for the page to draw from here on
    wait_for(lambda: driver.find_elements(By.XPATH, "//label[normalize-space()='goal x']"), 30.0, "the goal fields")
    for label, value in (("goal x", 0.52), ("goal y", -0.21), ("goal z", 0.33)):
        _set_field(driver, label, value)
    suite.goals.clear()
    driver.find_element(By.XPATH, "//button[normalize-space()='Send goal']").click()
    goal = wait_for(lambda: suite.goals[-1] if suite.goals else None, 10.0, "goal_pose")
    p = goal.pose.position
    assert goal.header.frame_id == "world"
    assert (p.x, p.y, p.z) == pytest.approx((0.52, -0.21, 0.33), abs=1e-6)
    q = goal.pose.orientation
    assert np.linalg.norm([q.x, q.y, q.z, q.w]) == pytest.approx(1.0, abs=1e-6)

    # the gizmo moved with the fields
    def gizmo_at_goal():
        position = (scene_nodes(driver) or {}).get("/goal", {}).get("position")
        return position is not None and np.allclose(position, [0.52, -0.21, 0.33], atol=1e-4)

    wait_for(gizmo_at_goal, 5.0, "the gizmo at the goal")


@pytest.mark.ros
@pytest.mark.slow
@pytest.mark.timeout(60)
def test_dragging_the_goal_gizmo_sends_goals_that_follow_it(view_page):
    driver, suite, _ = view_page
    before = np.array(scene_nodes(driver)["/goal"]["position"])
    # press on the gizmo's x arrow (local frame: 0.14 m out of its 0.18 m) and pull it out to 0.3 m
    start, end = screen_offsets(driver, "/goal", [(0.14, 0.0, 0.0), (0.3, 0.0, 0.0)])
    suite.goals.clear()
    drag(driver, start, end)

    def moved():
        after = (scene_nodes(driver) or {}).get("/goal", {}).get("position")
        return after if after is not None and np.linalg.norm(np.array(after) - before) > 0.03 else None

    after = np.array(wait_for(moved, 10.0, "the gizmo to move"))
    wait_for(lambda: suite.goals, 5.0, "goal_pose while dragging")
    time.sleep(0.5)  # the last goal of the drag
    p = suite.goals[-1].pose.position
    assert np.allclose([p.x, p.y, p.z], after, atol=1e-3), "the last goal is not where the gizmo was left"


@pytest.mark.ros
@pytest.mark.slow
@pytest.mark.timeout(60)
def test_the_enable_box_calls_the_planners_enable_service(view_page):
    from selenium.webdriver.common.by import By

    driver, suite, _ = view_page
    label = driver.find_element(By.XPATH, "//label[normalize-space()='Planner enabled']")
    box = driver.find_element(By.ID, label.get_attribute("for"))
    wait_for(lambda: not box.is_selected(), 10.0, "the box to show the planner disabled (from its status)")
    suite.enable_requests.clear()
    driver.execute_script("arguments[0].click();", box)
    assert wait_for(lambda: suite.enable_requests, 10.0, "a planner/enable request") == [True]


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
    wait_for(lambda: np.allclose(hand(), target, atol=1e-3), 10.0, "the robot at the new joint state after the pause")
    suite.q = Q.copy()

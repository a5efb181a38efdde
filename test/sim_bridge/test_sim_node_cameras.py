"""The sim node with several depth cameras: every configured camera's cloud and pose on its own topics."""

from __future__ import annotations

import json
import os
import random
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

REPO = Path(__file__).resolve().parents[2]
CAMERAS = ("camera", "left", "shelf_front", "shelf_side")  # two listed, two from the shelf scenario file
LEFT = [0.4, -1.1, 1.0]

PROBE = r"""
import json, sys, time
import rclpy
from rcl_interfaces.msg import Parameter, ParameterType, ParameterValue
from rcl_interfaces.srv import SetParameters
from geometry_msgs.msg import PoseStamped
from sensor_msgs.msg import PointCloud2
from msg_adapters import cloud_to_xyz

names = json.loads(sys.argv[1])
rclpy.init()
node = rclpy.create_node("sim_cameras_probe")
clouds, poses = {n: [] for n in names}, {n: [] for n in names}
for n in names:
    node.create_subscription(PointCloud2, f"{n}/points", lambda m, n=n: clouds[n].append(m), 5)
    node.create_subscription(PoseStamped, f"{n}/pose", lambda m, n=n: poses[n].append(m), 5)

def spin_until(cond, timeout):
    end = time.monotonic() + timeout
    while not cond() and time.monotonic() < end:
        rclpy.spin_once(node, timeout_sec=0.05)
    return cond()

assert spin_until(lambda: all(len(clouds[n]) >= 2 and poses[n] for n in names), 90.0), {
    n: (len(clouds[n]), len(poses[n])) for n in names}
out = {}
for n in names:
    cloud, pose = clouds[n][-1], poses[n][-1]
    p = pose.pose.position
    out[n] = {"frame": cloud.header.frame_id, "n": len(cloud_to_xyz(cloud)), "pose_frame": pose.header.frame_id,
              "position": [p.x, p.y, p.z], "stamp": cloud.header.stamp.sec + 1e-9 * cloud.header.stamp.nanosec}
client = node.create_client(SetParameters, "sim/set_parameters")
assert client.wait_for_service(timeout_sec=10.0)
def set_param(p):
    future = client.call_async(SetParameters.Request(parameters=[p]))
    rclpy.spin_until_future_complete(node, future, timeout_sec=10.0)
    r = future.result().results[0]
    return [r.successful, r.reason]
out["bad_left"] = set_param(Parameter(name="left.fovy", value=ParameterValue(
    type=ParameterType.PARAMETER_DOUBLE, double_value=-1.0)))
out["good_left"] = set_param(Parameter(name="left.fovy", value=ParameterValue(
    type=ParameterType.PARAMETER_DOUBLE, double_value=60.0)))
out["cameras_change"] = set_param(Parameter(name="cameras", value=ParameterValue(
    type=ParameterType.PARAMETER_STRING_ARRAY, string_array_value=["camera"])))
print(json.dumps(out))
"""


def child_env(domain_id: int) -> dict[str, str]:
    env = dict(os.environ, ROS_DOMAIN_ID=str(domain_id), PYTHONUNBUFFERED="1")
    env["PYTHONPATH"] = os.pathsep.join([str(REPO), *filter(None, [env.get("PYTHONPATH")])])
    return env


@pytest.mark.ros
@pytest.mark.slow
@pytest.mark.timeout(150)
def test_sim_node_publishes_every_cameras_cloud_and_pose():
    env = child_env(random.SystemRandom().randint(1, 100))
    sim_cmd = [sys.executable, "-m", "latent_planner_ros", "run", "sim", "--ros-args", "-p", "scenario:=shelf"]
    sim_cmd += ["-p", "cameras:=[camera, left]", "-p", f"left.position:={LEFT}", "-p", "camera.width:=160"]
    sim_cmd += ["-p", "camera.height:=120", "-p", "real_time_factor:=0.5"]
    sim = subprocess.Popen(sim_cmd, cwd=REPO, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        probe = subprocess.run(
            [sys.executable, "-c", PROBE, json.dumps(CAMERAS)],
            cwd=REPO,
            env=env,
            capture_output=True,
            text=True,
            timeout=120,
        )
        assert sim.poll() is None, "the sim stopped"
    finally:
        if sim.poll() is None:
            sim.send_signal(2)
        _, log = sim.communicate(timeout=20)
    assert probe.returncode == 0, f"probe failed:\n{probe.stderr[-3000:]}\nsim:\n{log[-3000:]}"
    out = json.loads(probe.stdout.strip().splitlines()[-1])
    assert "Traceback" not in log, log[-3000:]
    assert "depth cameras: camera (parameters) on camera/points, left (parameters) on left/points" in log
    for name in CAMERAS:
        assert out[name]["frame"] == "world" and out[name]["pose_frame"] == "world", name
        assert out[name]["n"] > 100, name
    np.testing.assert_allclose(out["camera"]["position"], [1.6, 0.7, 0.9], atol=1e-5)
    np.testing.assert_allclose(out["left"]["position"], LEFT, atol=1e-5)
    np.testing.assert_allclose(out["shelf_front"]["position"], [1.3, -0.2, 0.22], atol=1e-5)
    np.testing.assert_allclose(out["shelf_side"]["position"], [0.55, -1.2, 0.5], atol=1e-5)
    assert not out["bad_left"][0] and "left.fovy" in out["bad_left"][1]
    assert out["good_left"][0]
    assert not out["cameras_change"][0] and "read-only parameter: cameras" in out["cameras_change"][1]

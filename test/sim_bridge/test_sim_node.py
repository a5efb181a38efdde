"""The sim node as a process: rates, a decodable cloud, collision reporting, command refusal, reset, parameters."""

from __future__ import annotations

import json
import os
import random
import re
import subprocess
import sys
import time
from pathlib import Path

import imageio.v3 as iio
import numpy as np
import pytest
import yaml
from scipy.spatial.transform import Rotation

REPO = Path(__file__).resolve().parents[2]

PROBE = r"""
import json, sys, time
import numpy as np
import rclpy
from rcl_interfaces.msg import Parameter, ParameterType, ParameterValue
from rcl_interfaces.srv import SetParameters
from geometry_msgs.msg import PoseStamped
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import JointState, PointCloud2
from std_msgs.msg import Bool
from std_srvs.srv import Trigger
from msg_adapters import cloud_to_xyz, joint_state_to_q, q_to_joint_state

rclpy.init()
node = rclpy.create_node("sim_probe")
got = {"joints": [], "clouds": [], "clock": [], "collision": [], "camera": []}
node.create_subscription(JointState, "joint_states", lambda m: got["joints"].append((time.monotonic(), m)), 50)
node.create_subscription(PointCloud2, "camera/points", lambda m: got["clouds"].append(m), 5)
node.create_subscription(PoseStamped, "camera/pose", lambda m: got["camera"].append(m), 5)
node.create_subscription(Clock, "/clock", lambda m: got["clock"].append(m), 50)
node.create_subscription(Bool, "sim/in_collision", lambda m: got["collision"].append(m.data), 50)
command = node.create_publisher(JointState, "joint_command", 10)

def spin_until(cond, timeout):
    end = time.monotonic() + timeout
    while not cond() and time.monotonic() < end:
        rclpy.spin_once(node, timeout_sec=0.05)
    return cond()

def call(srv_type, name, request, timeout=10.0):
    client = node.create_client(srv_type, name)
    assert client.wait_for_service(timeout_sec=timeout), f"no service {name}"
    future = client.call_async(request)
    rclpy.spin_until_future_complete(node, future, timeout_sec=timeout)
    return future.result()

out = {}
assert spin_until(lambda: len(got["joints"]) > 0, 60.0), "no joint_states"
spin_until(lambda: False, 2.0)  # let start-up settle
got["joints"].clear()
start = time.monotonic()
spin_until(lambda: False, 4.0)
stamps = [t for t, _ in got["joints"] if t >= start]
out["joint_rate"] = (len(stamps) - 1) / (stamps[-1] - stamps[0])
q, dq = joint_state_to_q(got["joints"][-1][1])
out["q"], out["has_velocity"] = q.tolist(), dq is not None
assert spin_until(lambda: len(got["clouds"]) > 0, 10.0), "no camera/points"
cloud = got["clouds"][-1]
points = cloud_to_xyz(cloud)
out["cloud"] = {"n": len(points), "frame": cloud.header.frame_id, "zmin": float(points[:, 2].min())}
assert spin_until(lambda: any(p.header.stamp == cloud.header.stamp for p in got["camera"]), 5.0), "no camera/pose"
pose = next(p for p in got["camera"] if p.header.stamp == cloud.header.stamp)
o = pose.pose.orientation
out["camera"] = {"frame": pose.header.frame_id, "position": [pose.pose.position.x, pose.pose.position.y,
                 pose.pose.position.z], "quaternion_xyzw": [o.x, o.y, o.z, o.w]}
out["clock_msgs"] = len(got["clock"])
out["collision_before"] = any(got["collision"])

names = [f"panda_joint{i}" for i in range(1, 8)]
command.publish(JointState(name=names, position=[float("nan")] + q[1:].tolist()))
spin_until(lambda: False, 0.5)
command.publish(q_to_joint_state(np.r_[q, 0.0], names=names + ["elbow"]))
spin_until(lambda: False, 0.5)
reach = np.asarray(json.loads(sys.argv[1]))
got["collision"].clear()
def push():
    command.publish(q_to_joint_state(reach))
    return any(got["collision"])
out["collision_after_reach"] = spin_until(push, 10.0)

response = call(Trigger, "sim/reset", Trigger.Request())
out["reset"] = [response.success, response.message]
got["collision"].clear()
spin_until(lambda: len(got["collision"]) > 20, 5.0)
out["collision_after_reset"] = any(got["collision"][5:])

param = Parameter(name="camera.fovy", value=ParameterValue(type=ParameterType.PARAMETER_DOUBLE, double_value=-5.0))
result = call(SetParameters, "sim/set_parameters", SetParameters.Request(parameters=[param])).results[0]
out["bad_param"] = [result.successful, result.reason]
param = Parameter(name="scenario", value=ParameterValue(type=ParameterType.PARAMETER_STRING, string_value="nowhere"))
result = call(SetParameters, "sim/set_parameters", SetParameters.Request(parameters=[param])).results[0]
out["bad_scenario"] = [result.successful, result.reason]
param = Parameter(name="use_sim_time", value=ParameterValue(type=ParameterType.PARAMETER_BOOL, bool_value=False))
result = call(SetParameters, "sim/set_parameters", SetParameters.Request(parameters=[param])).results[0]
out["use_sim_time"] = result.successful

targets = []
node.create_subscription(PoseStamped, "target_pose", targets.append, 10)
param = Parameter(name="scenario", value=ParameterValue(type=ParameterType.PARAMETER_STRING, string_value="conveyor"))
result = call(SetParameters, "sim/set_parameters", SetParameters.Request(parameters=[param])).results[0]
response = call(Trigger, "sim/reset", Trigger.Request())
out["conveyor"] = [result.successful, response.success, response.message]
spin_until(lambda: len(targets) > 3, 10.0)
out["targets"] = [[t.header.frame_id, t.pose.position.y, t.pose.position.z, t.pose.orientation.x] for t in targets]
print(json.dumps(out))
"""

BLOCK = {
    "name": "block",
    "objects": [{"name": "block", "type": "box", "half_extents": [0.05, 0.15, 0.05], "position": [0.5, 0.0, 0.4]}],
}
READY = [0.0, -0.785398, 0.0, -2.35619, 0.0, 1.5707, 0.785398]
REACH = [0.0, -0.085398, 0.0, -1.85619, 0.0, 1.5707, 0.785398]  # hand forward and down into the block


def child_env(domain_id: int) -> dict[str, str]:
    env = dict(os.environ, ROS_DOMAIN_ID=str(domain_id), PYTHONUNBUFFERED="1")
    env["PYTHONPATH"] = os.pathsep.join([str(REPO), *filter(None, [env.get("PYTHONPATH")])])
    return env


def stop(proc: subprocess.Popen) -> str:
    """Interrupt (then kill) a child; returns its stderr."""
    if proc.poll() is None:
        proc.send_signal(2)
    try:
        _, err = proc.communicate(timeout=10)
    except subprocess.TimeoutExpired:
        proc.kill()
        _, err = proc.communicate(timeout=5)
    return err or ""


@pytest.mark.ros
@pytest.mark.slow
@pytest.mark.timeout(150)
def test_sim_node_end_to_end(tmp_path):
    scenario = tmp_path / "block.yaml"
    scenario.write_text(yaml.safe_dump(BLOCK))
    env = child_env(random.SystemRandom().randint(1, 100))
    sim_cmd = [sys.executable, "-m", "latent_planner_ros", "run", "sim", "--ros-args"]
    sim_cmd += ["--params-file", str(REPO / "config" / "sim.yaml"), "-p", f"scenario:={scenario}"]
    procs = []
    try:
        sim = subprocess.Popen(sim_cmd, cwd=REPO, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        procs.append(sim)
        probe = subprocess.Popen(
            [sys.executable, "-c", PROBE, json.dumps(REACH)],
            cwd=REPO,
            env=env,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )
        procs.append(probe)
        out, err = probe.communicate(timeout=120)
        assert probe.returncode == 0, f"probe failed:\n{err}\nsim:\n{stop(sim)}"
        result = json.loads(out.strip().splitlines()[-1])
    finally:
        logs = [stop(p) for p in procs]
    sim_log = logs[0]

    assert 90.0 <= result["joint_rate"] <= 110.0, result["joint_rate"]
    assert result["has_velocity"] and max(abs(a - b) for a, b in zip(result["q"], READY, strict=True)) < 1e-3
    assert result["cloud"]["frame"] == "world" and result["cloud"]["n"] > 1000
    assert result["cloud"]["zmin"] > -0.03
    # camera/pose with the cloud's stamp: the configured optical centre, looking (along -z) at look_at
    camera = yaml.safe_load((REPO / "config" / "sim.yaml").read_text())["sim"]["ros__parameters"]["camera"]
    assert result["camera"]["frame"] == "world"
    np.testing.assert_allclose(result["camera"]["position"], camera["position"], atol=1e-5)
    view = Rotation.from_quat(result["camera"]["quaternion_xyzw"]).apply([0.0, 0.0, -1.0])
    towards = np.subtract(camera["look_at"], camera["position"])
    np.testing.assert_allclose(view, towards / np.linalg.norm(towards), atol=1e-6)
    assert result["clock_msgs"] > 100
    assert not result["collision_before"]
    assert result["collision_after_reach"]
    assert result["reset"][0] and "block" in result["reset"][1]
    assert not result["collision_after_reset"]
    assert not result["bad_param"][0] and "camera.fovy" in result["bad_param"][1]
    assert not result["bad_scenario"][0] and "unknown scenario 'nowhere'" in result["bad_scenario"][1]
    assert result["use_sim_time"], "ROS's own parameters are not ours to refuse"
    assert "refused: JointState position is NaN" in sim_log, sim_log[-3000:]
    assert "refused: unknown joints ['elbow']" in sim_log, sim_log[-3000:]
    assert result["conveyor"][:2] == [True, True] and "conveyor" in result["conveyor"][2]
    frames, ys, zs, qx = zip(*result["targets"], strict=True)
    assert set(frames) == {"world"} and len(set(ys)) > 1, "the target moves along the belt"
    assert all(abs(z - 0.2) < 1e-6 for z in zs) and all(abs(x - 1.0) < 1e-6 for x in qx)


@pytest.mark.ros
@pytest.mark.slow
@pytest.mark.timeout(90)
def test_record_writes_a_gif_on_ctrl_c(tmp_path):
    gif = tmp_path / "out.gif"
    env = child_env(random.SystemRandom().randint(1, 100))
    cmd = [sys.executable, "-m", "latent_planner_ros", "run", "sim", "--record", str(gif), "--record-size", "160x120"]
    sim = subprocess.Popen(cmd, cwd=REPO, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        time.sleep(8.0)
    finally:
        log = stop(sim)
    assert sim.returncode == 0, log
    assert "Traceback" not in log
    written = re.search(r"wrote (\d+) pictures", log)
    assert written and int(written.group(1)) >= 10, log  # 10 per simulated second
    frames = iio.imread(gif, index=None)  # (identical frames of the still arm are merged in the GIF)
    assert frames.shape[1:3] == (120, 160)

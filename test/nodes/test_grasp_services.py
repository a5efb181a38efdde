"""Both planner nodes answer a grasp goal on ~/plan_grasp: the object's points set aside, a checked approach."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import numpy as np
import pytest

from test.nodes.test_planner_node import REPO, _run, _stop
from test.planning.test_grasp import BOARD, GOAL, OBJECT, _start, _surface

PROBE = r"""
import json, sys, time
import numpy as np
import rclpy
from diagnostic_msgs.msg import DiagnosticStatus
from diagnostic_msgs.msg import DiagnosticArray
from nav_msgs.srv import GetPlan
from sensor_msgs.msg import JointState, PointCloud2
from visualization_msgs.msg import Marker
from latent_planner_ros.robot.rotations import matrix_to_quat
from msg_adapters import box_to_marker, q_to_joint_state, target_to_pose_stamped, xyz_to_cloud
from latent_planner_ros.planning.goal import Goal

data = np.load(sys.argv[1])
cloud, start = data["cloud"].astype(np.float32), data["start"]
GOAL = Goal(data["goal_position"], data["goal_rotation"])
rclpy.init()
node = rclpy.create_node("grasp_probe")
joints = node.create_publisher(JointState, "joint_states", 10)
clouds = node.create_publisher(PointCloud2, "camera/points", 2)
results = []
node.create_subscription(DiagnosticStatus, "planner/plan_result", lambda m: results.append(m.message), 10)
node.create_subscription(DiagnosticStatus, "ompl_planner/plan_result", lambda m: results.append(m.message), 10)
boxes = node.create_publisher(Marker, "grasp_target", 10)
box = data["box"] if "box" in data else None  # (centre (3), half extents (3)) of a caller's target box
status = {}
for name in ("planner", "ompl_planner"):
    node.create_subscription(DiagnosticArray, f"{name}/status", lambda m, n=name: status.__setitem__(
        n, {kv.key: kv.value for kv in m.status[0].values}), 10)

def publish_inputs():
    stamp = node.get_clock().now().to_msg()
    joints.publish(q_to_joint_state(start, stamp=stamp))
    msg = xyz_to_cloud(cloud, frame_id="world")
    msg.header.stamp = stamp
    clouds.publish(msg)
    if box is not None:
        boxes.publish(box_to_marker(box[0], np.array([0.0, 0.0, 0.0, 1.0]), box[1]))

node.create_timer(0.1, publish_inputs)
out = {}
goal = target_to_pose_stamped(GOAL.position, matrix_to_quat(GOAL.rotation))
for name in ("planner", "ompl_planner"):
    client = node.create_client(GetPlan, f"{name}/plan_grasp")
    assert client.wait_for_service(timeout_sec=60.0), f"no {name}/plan_grasp"
    end = time.monotonic() + 2.0
    while time.monotonic() < end:  # the cloud and joint states reach the node
        rclpy.spin_once(node, timeout_sec=0.05)
    n = len(results)
    future = client.call_async(GetPlan.Request(goal=goal))
    rclpy.spin_until_future_complete(node, future, timeout_sec=90.0)
    end = time.monotonic() + 5.0
    while len(results) == n and time.monotonic() < end:
        rclpy.spin_once(node, timeout_sec=0.05)
    poses = future.result().plan.poses
    last = poses[-1].pose.position if poses else None
    out[name] = {
        "poses": len(poses),
        "end_err": float(np.linalg.norm(np.array([last.x, last.y, last.z]) - GOAL.position)) if last else None,
        "result": results[n] if len(results) > n else "",
        "grasp_target": status.get(name, {}).get("grasp_target", ""),
    }
print("RESULT " + json.dumps(out), flush=True)
"""


@pytest.mark.ros
@pytest.mark.slow
def test_both_planner_nodes_answer_a_grasp_goal(tmp_path):
    """A box standing on a board (test/planning/test_grasp.py), the whole of both seen, the TCP at the box."""
    inputs = tmp_path / "grasp.npz"
    cloud = np.concatenate([_surface(BOARD), _surface(OBJECT)])
    np.savez(inputs, cloud=cloud, start=_start(), goal_position=GOAL.position, goal_rotation=GOAL.rotation)
    env = dict(os.environ, PYTHONUNBUFFERED="1")
    planner = ["--params-file", "config/planner.yaml", "-p", "amp_ls.collision_backend:=geometric"]
    ompl = ["--params-file", "config/ompl_planner.yaml", "-p", "grasp_target_radius_m:=0.06"]  # a caller's radius
    procs = [_run("planner", planner, env), _run("ompl_planner", ompl, env)]
    try:
        probe = subprocess.run(
            [sys.executable, "-c", PROBE, str(inputs)], cwd=REPO, env=env, capture_output=True, text=True, timeout=300
        )
    finally:
        logs = _stop(procs)
    line = next((x for x in probe.stdout.splitlines() if x.startswith("RESULT ")), None)
    assert line, f"probe failed:\n{probe.stdout}\n{probe.stderr[-3000:]}\n{logs}"
    out = json.loads(line[len("RESULT ") :])
    for name in ("planner", "ompl_planner"):
        r = out[name]
        assert r["poses"] > 1 and r["end_err"] < 0.01, (name, r, logs[-3000:])
        assert r["result"].startswith("reached") and "target points set aside" in r["result"], (name, r)
        points = int(r["result"].split("grasp: ")[1].split()[0])
        assert points > (500 if name == "planner" else 300), r  # the object's points (found, or within 6 cm)


@pytest.mark.ros
@pytest.mark.slow
def test_a_callers_box_on_grasp_target_is_the_target_of_both_nodes(tmp_path):
    """The same box and cloud as above; the box (4.4 x 3.4 x 14.4 cm around the object) is published on
    grasp_target: exactly the cloud's points inside it are set aside, by both nodes alike."""
    from latent_planner_ros.perception.grasp_target import TargetBox

    inputs = tmp_path / "grasp.npz"
    cloud = np.concatenate([_surface(BOARD), _surface(OBJECT)])
    half = np.asarray(OBJECT.half_extents) + 0.002
    box = np.stack([np.asarray(OBJECT.position), half])
    inside = int(TargetBox(box[0], np.eye(3), box[1]).contains(cloud).sum())
    np.savez(inputs, cloud=cloud, start=_start(), goal_position=GOAL.position, goal_rotation=GOAL.rotation, box=box)
    env = dict(os.environ, PYTHONUNBUFFERED="1")
    planner = ["--params-file", "config/planner.yaml", "-p", "amp_ls.collision_backend:=geometric"]
    ompl = ["--params-file", "config/ompl_planner.yaml", "-p", "grasp_target_radius_m:=0.06"]  # the box wins
    procs = [_run("planner", planner, env), _run("ompl_planner", ompl, env)]
    try:
        probe = subprocess.run(
            [sys.executable, "-c", PROBE, str(inputs)], cwd=REPO, env=env, capture_output=True, text=True, timeout=300
        )
    finally:
        logs = _stop(procs)
    line = next((x for x in probe.stdout.splitlines() if x.startswith("RESULT ")), None)
    assert line, f"probe failed:\n{probe.stdout}\n{probe.stderr[-3000:]}\n{logs}"
    out = json.loads(line[len("RESULT ") :])
    for name in ("planner", "ompl_planner"):
        r = out[name]
        assert r["poses"] > 1 and r["end_err"] < 0.01, (name, r, logs[-3000:])
        assert r["result"].startswith("reached") and f"grasp: {inside} target points" in r["result"], (name, r)
        assert r["grasp_target"].startswith("box 4 x 3 x 14 cm"), r

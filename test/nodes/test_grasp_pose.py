"""A grasp goal on the planner's `grasp_pose` topic: the closed loop sets the object's points aside, follows a
background plan_grasp (pre-grasp, straight approach) and reaches the grasp; status names the points set aside."""

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
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import PoseStamped
from sensor_msgs.msg import JointState, PointCloud2
from latent_planner_ros.planning.goal import Goal
from latent_planner_ros.robot.panda import load_panda
from latent_planner_ros.robot.rotations import matrix_to_quat
from msg_adapters import q_to_joint_state, target_to_pose_stamped, xyz_to_cloud

data = np.load(sys.argv[1])
cloud, goal = data["cloud"].astype(np.float32), Goal(data["goal_position"], data["goal_rotation"])
rclpy.init()
node = rclpy.create_node("grasp_pose_probe")
state = {"q": data["start"].copy(), "status": {}, "commands": [], "sources": set()}

def on_command(msg):  # a fake arm: it is wherever the last command sent it
    state["q"] = np.asarray(msg.position[:7], dtype=float)
    state["commands"].append(state["q"].tolist())

def on_status(msg):
    s = msg.status[0]
    state["status"] = {"message": s.message, **{kv.key: kv.value for kv in s.values}}
    state["sources"].add(state["status"].get("command_source", ""))

node.create_subscription(JointState, "joint_command", on_command, 10)
node.create_subscription(DiagnosticArray, "planner/status", on_status, 10)
joints = node.create_publisher(JointState, "joint_states", 10)
clouds = node.create_publisher(PointCloud2, "camera/points", 2)
grasp_pub = node.create_publisher(PoseStamped, "grasp_pose", 10)

def publish_inputs():
    stamp = node.get_clock().now().to_msg()
    joints.publish(q_to_joint_state(state["q"], stamp=stamp))
    msg = xyz_to_cloud(cloud, frame_id="world")
    msg.header.stamp = stamp
    clouds.publish(msg)

node.create_timer(0.05, publish_inputs)

def spin_until(cond, timeout):
    end = time.monotonic() + timeout
    while not cond() and time.monotonic() < end:
        rclpy.spin_once(node, timeout_sec=0.05)
    return cond()

assert spin_until(lambda: "cloud_points_in" in state["status"], 120.0), "no planner status"
assert spin_until(lambda: grasp_pub.get_subscription_count() > 0, 10.0), "planner not subscribed to grasp_pose"
spin_until(lambda: False, 1.0)  # the cloud reaches the planner
grasp_pub.publish(target_to_pose_stamped(goal.position, matrix_to_quat(goal.rotation)))
spin_until(lambda: "target points set aside" in state["status"].get("grasp", ""), 10.0)
out = {"grasp_status": dict(state["status"])}
panda = load_panda()
err = lambda: float(np.linalg.norm(panda.fk(state["q"]).translation - goal.position))
reached = spin_until(lambda: err() < 0.01 and state["status"].get("message", "").startswith("reached"), 60.0)
out.update(reached=bool(reached), err=err(), status=state["status"], commands=state["commands"],
           sources=sorted(state["sources"]))
print("RESULT " + json.dumps(out), flush=True)
"""


@pytest.mark.ros
@pytest.mark.slow
def test_a_grasp_goal_on_grasp_pose_is_reached_along_a_plan_without_touching_the_object(tmp_path):
    from latent_planner_ros.data.scene import Scene
    from latent_planner_ros.evaluation.path_check import PathJudge

    inputs = tmp_path / "grasp.npz"
    cloud = np.concatenate([_surface(BOARD), _surface(OBJECT)])
    np.savez(inputs, cloud=cloud, start=_start(), goal_position=GOAL.position, goal_rotation=GOAL.rotation)
    env = dict(os.environ, PYTHONUNBUFFERED="1")
    params = ["--params-file", "config/planner.yaml", "-p", "amp_ls.collision_backend:=geometric"]
    params += ["-p", "enabled:=true", "-p", "status_rate_hz:=10.0"]
    procs = [_run("planner", params, env)]
    try:
        probe = subprocess.run(
            [sys.executable, "-c", PROBE, str(inputs)], cwd=REPO, env=env, capture_output=True, text=True, timeout=300
        )
    finally:
        logs = _stop(procs)
    line = next((x for x in probe.stdout.splitlines() if x.startswith("RESULT ")), None)
    assert line, f"probe failed:\n{probe.stdout}\n{probe.stderr[-3000:]}\n{logs}"
    out = json.loads(line[len("RESULT ") :])
    assert out["reached"], json.dumps([out["err"], out["grasp_status"], out["status"], logs[-3000:]], indent=1)
    assert int(out["grasp_status"]["grasp"].split()[0]) > 500, out["grasp_status"]  # the object's points
    assert "local" not in out["sources"], out["sources"]  # only along the plan, never a local step
    path = np.concatenate([_start()[None], np.array(out["commands"])])
    verdict = PathJudge(Scene((BOARD, OBJECT)), table=True).judge(path, GOAL)
    assert verdict.reached and verdict.collision == "", verdict

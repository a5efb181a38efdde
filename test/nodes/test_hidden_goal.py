"""The planner node refuses a goal hidden just behind what its camera sees (the camera's pose on `camera/pose`
beside `camera/points`), with the reason on its status, and takes a goal above the same object."""

from __future__ import annotations

import os

import pytest

from test.nodes.test_planner_node import _run, probe_result

PROBE = r"""
import json, time
import numpy as np
import rclpy
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import PoseStamped
from sensor_msgs.msg import JointState, PointCloud2
from latent_planner_ros.data.camera import CameraIntrinsics, look_at
from latent_planner_ros.data.obstacles import Box
from latent_planner_ros.data.render import depth_to_points, render_depth
from latent_planner_ros.data.scene import Scene
from latent_planner_ros.robot.limits import Q_READY
from latent_planner_ros.robot.rotations import matrix_to_quat
from msg_adapters import q_to_joint_state, target_to_pose_stamped, xyz_to_cloud

centre, eye = np.array([0.5, 0.0, 0.12]), np.array([1.6, 0.0, 0.5])
box = Box(position=tuple(centre), quaternion_xyzw=(0.0, 0.0, 0.0, 1.0), half_extents=(0.06, 0.06, 0.06))
pose = look_at(eye, centre)
cloud = depth_to_points(render_depth(Scene(obstacles=(box,)), pose, CameraIntrinsics()), pose, CameraIntrinsics())
down = matrix_to_quat(np.diag([1.0, -1.0, -1.0]))

rclpy.init()
node = rclpy.create_node("hidden_goal_probe")
state = {"errors": [], "states": []}

def on_status(msg):
    values = {kv.key: kv.value for kv in msg.status[0].values}
    state["errors"].append(values.get("last_error", ""))
    state["states"].append(values.get("state", ""))
    state["camera_poses"] = values.get("camera_poses", "")

node.create_subscription(DiagnosticArray, "planner/status", on_status, 10)
joints = node.create_publisher(JointState, "joint_states", 10)
clouds = node.create_publisher(PointCloud2, "camera/points", 2)
poses = node.create_publisher(PoseStamped, "camera/pose", 10)
goals = node.create_publisher(PoseStamped, "goal_pose", 10)

def publish_inputs():
    stamp = node.get_clock().now().to_msg()
    joints.publish(q_to_joint_state(Q_READY, stamp=stamp))
    poses.publish(target_to_pose_stamped(eye, matrix_to_quat(pose[:3, :3]), stamp=stamp))
    clouds.publish(xyz_to_cloud(cloud.astype(np.float32), frame_id="world", stamp=stamp))

node.create_timer(0.05, publish_inputs)

def spin_until(cond, timeout):
    end = time.monotonic() + timeout
    while not cond() and time.monotonic() < end:
        rclpy.spin_once(node, timeout_sec=0.02)
    return cond()

out = {}
spin_until(lambda: len(state["states"]) > 3, 60.0)
out["camera_poses_before"] = state.get("camera_poses")
out["camera_known"] = spin_until(lambda: state.get("camera_poses") == "1", 30.0)  # the pose has reached the planner
goals.publish(target_to_pose_stamped(centre, down))
out["refused"] = spin_until(lambda: any("hidden" in e for e in state["errors"]), 10.0)
out["error"] = next((e for e in state["errors"] if "hidden" in e), state["errors"][-1] if state["errors"] else "")
n = len(state["states"])
goals.publish(target_to_pose_stamped(centre + np.array([0.0, 0.0, 0.15]), down))
out["taken"] = spin_until(lambda: any(s in ("tracking", "reached") for s in state["states"][n:]), 10.0)
out["states_after"] = sorted(set(state["states"][n:]))
print("RESULT " + json.dumps(out), flush=True)
"""


@pytest.mark.ros
@pytest.mark.slow
def test_planner_node_refuses_a_goal_hidden_behind_an_observed_surface():
    env = dict(os.environ, PYTHONUNBUFFERED="1")
    params = ["--params-file", "config/planner.yaml", "-p", "amp_ls.collision_backend:=geometric"]
    procs = [_run("planner", [*params, "-p", "enabled:=true", "-p", "status_rate_hz:=10.0"], env)]
    out, logs = probe_result(procs, PROBE, env, timeout=180)
    assert out["camera_known"], (out, logs[-3000:])  # status camera_poses: the camera's pose beside its cloud
    assert out["refused"] and "behind an observed surface from 1 camera(s)" in out["error"], (out, logs[-3000:])
    assert out["taken"], (out, logs[-3000:])
    assert all(p.returncode == 0 for p in procs), logs

"""The planner node as a process, with the sim: GetPlan, closed-loop reaching, refusals, command limits."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]

PROBE = r"""
import json, math, sys, time
import numpy as np
import rclpy
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import PoseStamped
from nav_msgs.srv import GetPlan
from sensor_msgs.msg import JointState
from latent_planner_ros.robot.limits import Q_MAX, Q_MIN, Q_READY, V_MAX
from latent_planner_ros.robot.panda import load_panda
from latent_planner_ros.robot.rotations import matrix_to_quat
from msg_adapters import joint_state_to_q, target_to_pose_stamped

rclpy.init()
node = rclpy.create_node("planner_probe")
state = {"q": None, "violations": [], "commands": 0, "status": []}

def on_joints(msg):
    state["q"] = joint_state_to_q(msg)[0]

def on_command(msg):
    state["commands"] += 1
    q_cmd = np.asarray(msg.position[:7], dtype=float)
    if not np.all(np.isfinite(q_cmd)) or np.any(q_cmd < Q_MIN - 1e-6) or np.any(q_cmd > Q_MAX + 1e-6):
        state["violations"].append(f"out of limits: {q_cmd.tolist()}")
    elif state["q"] is not None and np.any(np.abs(q_cmd - state["q"]) > V_MAX * 0.1 + 0.02):
        state["violations"].append(f"too fast: {np.abs(q_cmd - state['q']).max():.3f} rad in one period")

def on_status(msg):
    for s in msg.status:
        state["status"].append(s.message + " " + " ".join(f"{kv.key}={kv.value}" for kv in s.values))

node.create_subscription(JointState, "joint_states", on_joints, 10)
node.create_subscription(JointState, "joint_command", on_command, 10)
node.create_subscription(DiagnosticArray, "planner/status", on_status, 10)
goal_pub = node.create_publisher(PoseStamped, "goal_pose", 10)

def spin_until(cond, timeout):
    end = time.monotonic() + timeout
    while not cond() and time.monotonic() < end:
        rclpy.spin_once(node, timeout_sec=0.05)
    return cond()

panda = load_panda()
goal_q = Q_READY + np.array([0.5, 0.25, -0.2, 0.35, 0.1, -0.2, 0.3])
tf = panda.fk(goal_q)
quat = matrix_to_quat(tf.rotation)
goal = target_to_pose_stamped(tf.translation, quat)
out = {}
assert spin_until(lambda: state["q"] is not None, 60.0), "no joint_states"
client = node.create_client(GetPlan, "planner/plan")
assert client.wait_for_service(timeout_sec=60.0), "no planner/plan service"

def plan(pose, tolerance=0.0):
    future = client.call_async(GetPlan.Request(goal=pose, tolerance=tolerance))
    rclpy.spin_until_future_complete(node, future, timeout_sec=60.0)
    return future.result().plan

deadline = time.monotonic() + 30.0  # the first clouds may still be on their way
path = plan(goal)
while not path.poses and time.monotonic() < deadline:
    spin_until(lambda: False, 1.0)
    path = plan(goal)
out["plan_len"] = len(path.poses)
if path.poses:
    p = path.poses[-1].pose.position
    out["plan_end_err"] = float(np.linalg.norm(np.array([p.x, p.y, p.z]) - tf.translation))

# refusals: a NaN goal, a goal 3 m away; the node answers and keeps running
bad = target_to_pose_stamped(tf.translation, quat)
bad.pose.position.x = float("nan")
goal_pub.publish(bad)
out["status_nan"] = spin_until(lambda: any("goal_pose refused" in s for s in state["status"]), 5.0)
far = target_to_pose_stamped(np.array([3.0, 0.0, 0.5]), quat)
out["far_plan_len"] = len(plan(far).poses)
spin_until(lambda: any("reach" in s for s in state["status"]), 5.0)
out["status_far"] = any("beyond the reach" in s for s in state["status"])

# closed loop: the arm reaches the goal through joint_command
def tcp_err():
    return float(np.linalg.norm(panda.fk(state["q"]).translation - tf.translation))
goal_pub.publish(goal)
t0 = time.monotonic()
reached = spin_until(lambda: tcp_err() < 0.015, 60.0)
out["closed_loop_reached"] = reached
out["closed_loop_s"] = time.monotonic() - t0
out["final_err"] = tcp_err()
out["commands"] = state["commands"]
out["violations"] = state["violations"][:5]
print("RESULT " + json.dumps(out), flush=True)
"""


def _run(name: str, args: list[str], env: dict) -> subprocess.Popen:
    cmd = [sys.executable, "-m", "latent_planner_ros", "run", name, "--ros-args", *args]
    return subprocess.Popen(cmd, cwd=REPO, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)


def _stop(procs: list[subprocess.Popen]) -> str:
    logs = []
    for p in procs:
        if p.poll() is None:
            p.send_signal(signal.SIGINT)
    for p in procs:
        try:
            out, _ = p.communicate(timeout=20)
        except subprocess.TimeoutExpired:
            p.kill()
            out, _ = p.communicate()
        logs.append(out[-3000:])
    return "\n".join(logs)


@pytest.mark.ros
@pytest.mark.slow
@pytest.mark.parametrize("backend", ["learned", "geometric"])
def test_planner_node_plans_reaches_and_refuses_bad_goals(backend):
    env = dict(os.environ, PYTHONUNBUFFERED="1")
    procs = [_run("sim", ["--params-file", "config/sim.yaml", "-p", "scenario:=empty"], env)]
    if backend == "learned":  # the scene arrives as embeddings from the scene_encoder node
        procs.append(
            _run("scene_encoder", ["--params-file", "config/scene_encoder.yaml", "-p", "use_sim_time:=true"], env)
        )
    params = ["--params-file", "config/planner.yaml", "-p", "use_sim_time:=true"]
    procs.append(_run("planner", [*params, "-p", f"amp_ls.collision_backend:={backend}"], env))
    try:
        probe = subprocess.run(
            [sys.executable, "-c", PROBE], cwd=REPO, env=env, capture_output=True, text=True, timeout=240
        )
    finally:
        logs = _stop(procs)
    line = next((x for x in probe.stdout.splitlines() if x.startswith("RESULT ")), None)
    assert line, f"probe failed:\n{probe.stdout}\n{probe.stderr[-3000:]}\n{logs}"
    out = json.loads(line[len("RESULT ") :])
    assert out["plan_len"] > 1 and out["plan_end_err"] < 0.01, out
    assert out["far_plan_len"] == 0 and out["status_far"] and out["status_nan"], out
    assert out["closed_loop_reached"], (out, logs)
    assert out["commands"] > 0 and out["violations"] == [], out
    assert all(p.returncode == 0 for p in procs), logs

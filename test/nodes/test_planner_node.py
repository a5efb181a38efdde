"""The planner node as a process, with the sim: GetPlan, closed-loop reaching, refusals, command limits."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

REPO = Path(__file__).resolve().parents[2]

PROBE = r"""
import json, math, sys, time
import numpy as np
import rclpy
from builtin_interfaces.msg import Time
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from geometry_msgs.msg import PoseStamped
from nav_msgs.srv import GetPlan
from sensor_msgs.msg import JointState
from latent_planner_ros.robot.limits import Q_MAX, Q_MIN, Q_READY, V_MAX
from latent_planner_ros.robot.panda import load_panda
from latent_planner_ros.robot.rotations import matrix_to_quat
from msg_adapters import joint_state_to_q, target_to_pose_stamped

rclpy.init()
node = rclpy.create_node("planner_probe")
state = {"q": None, "violations": [], "commands": 0, "status": [], "status_values": [], "results": []}

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
        state["status_values"].append({kv.key: kv.value for kv in s.values})

def on_result(msg):
    state["results"].append([ord(msg.level), msg.name, msg.message, {kv.key: kv.value for kv in msg.values}])

node.create_subscription(JointState, "joint_states", on_joints, 10)
node.create_subscription(JointState, "joint_command", on_command, 10)
node.create_subscription(DiagnosticArray, "planner/status", on_status, 10)
node.create_subscription(DiagnosticStatus, "planner/plan_result", on_result, 10)
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

def with_result(pose, tolerance=0.0):  # (waypoints returned, the request's plan_result or None)
    n = len(state["results"])
    length = len(plan(pose, tolerance).poses)
    spin_until(lambda: len(state["results"]) > n, 5.0)
    return length, state["results"][n] if len(state["results"]) > n else None

out["far_plan_len"], out["far_result"] = with_result(far)
spin_until(lambda: any("reach" in s for s in state["status"]), 5.0)
out["status_far"] = any("beyond the reach" in s for s in state["status"])

# refused tolerances, then a successful plan clears last_error; every request answers on plan_result
out["neg_tol_len"], out["neg_tol_result"] = with_result(goal, -0.01)
out["nan_tol_len"], out["nan_tol_result"] = with_result(goal, float("nan"))
spin_until(lambda: "tolerance" in state["status_values"][-1].get("last_error", ""), 5.0)
out["last_error_before"] = state["status_values"][-1].get("last_error")
stamped = target_to_pose_stamped(tf.translation, quat, stamp=Time(sec=7, nanosec=5))
for _ in range(3):  # the same goal planned before; a retry only if the optimisation is unlucky
    out["replan_len"], out["replan_result"] = with_result(stamped)
    if out["replan_len"]:
        break
n = len(state["status_values"])
spin_until(lambda: len(state["status_values"]) > n, 5.0)
out["last_error_after"] = state["status_values"][-1].get("last_error") if len(state["status_values"]) > n else "-"

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
        except subprocess.TimeoutExpired:  # ask for its stacks (node_main: SIGUSR1), then kill it
            p.send_signal(signal.SIGUSR1)
            time.sleep(2.0)
            p.kill()
            out, _ = p.communicate()
            out += f"\n[test] {p.args[4]} did not exit within 20 s of SIGINT; its stacks are above"
        logs.append(out[-6000:])
    return "\n".join(logs)


def probe_result(procs: list[subprocess.Popen], probe: str, env: dict, timeout: float) -> tuple[dict, str]:
    """Run the probe script against the started nodes, stop them, and return the probe's RESULT (a dict) and the
    nodes' logs; fails the test when the probe printed no RESULT line."""
    try:
        run = subprocess.run(
            [sys.executable, "-c", probe], cwd=REPO, env=env, capture_output=True, text=True, timeout=timeout
        )
    finally:
        logs = _stop(procs)
    line = next((x for x in run.stdout.splitlines() if x.startswith("RESULT ")), None)
    assert line, f"probe failed:\n{run.stdout}\n{run.stderr[-3000:]}\n{logs}"
    return json.loads(line[len("RESULT ") :]), logs


@pytest.mark.ros
@pytest.mark.slow
@pytest.mark.parametrize("backend", ["learned", "geometric", "local"])
def test_planner_node_plans_reaches_and_refuses_bad_goals(backend):
    env = dict(os.environ, PYTHONUNBUFFERED="1")
    procs = [_run("sim", ["--params-file", "config/sim.yaml", "-p", "scenario:=empty"], env)]
    if backend == "learned":  # the scene arrives as embeddings from the scene_encoder node
        procs.append(
            _run("scene_encoder", ["--params-file", "config/scene_encoder.yaml", "-p", "use_sim_time:=true"], env)
        )
    params = ["--params-file", "config/planner.yaml", "-p", "use_sim_time:=true", "-p", "enabled:=true"]
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
    _check_plan_results(out, "planner")
    level, _, message, values = out["far_result"]
    assert level == 2 and message.startswith("refused: goal ") and "beyond the reach" in values["reason"], out
    assert out["closed_loop_reached"], (out, logs)
    assert out["commands"] > 0 and out["violations"] == [], out
    assert all(p.returncode == 0 for p in procs), logs


def _check_plan_results(out: dict, name: str) -> None:
    """The plan_result of each request in `out` (level, name, message, values)."""
    ERROR, OK = 2, 0
    for key in ("neg_tol", "nan_tol"):
        level, node, message, values = out[f"{key}_result"]
        assert out[f"{key}_len"] == 0 and (level, node) == (ERROR, name), out
        assert message.startswith("refused: tolerance must be 0") and values["success"] == "false", out
        assert values["reason"] in message and values["waypoints"] == "0" and "planning_time_s" not in values, out
    assert "tolerance must be 0" in out["last_error_before"], out
    level, node, message, values = out["replan_result"]
    assert out["replan_len"] > 1 and (level, node) == (OK, name), out
    assert message.startswith("reached in ") and values["success"] == "true" and values["reason"] == "reached", out
    assert values["request_stamp"] == "7.000000005" and int(values["waypoints"]) == out["replan_len"], out
    assert float(values["planning_time_s"]) > 0 and float(values["final_pos_err_m"]) < 0.01, out
    assert out["last_error_after"] == "", out


LSPP_PROBE = r"""
import json, sys, time
import numpy as np
import rclpy
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import PoseStamped
from nav_msgs.srv import GetPlan
from sensor_msgs.msg import JointState
from trajectory_msgs.msg import JointTrajectory
from visualization_msgs.msg import Marker, MarkerArray
from latent_planner_ros.robot.limits import Q_READY
from latent_planner_ros.robot.panda import load_panda
from msg_adapters import cylinders_to_marker_array, path_to_arrays, q_to_joint_state, target_to_pose_stamped
from msg_adapters import trajectory_to_arrays

cylinders, goal_position = np.array(json.loads(sys.argv[1])), np.array(json.loads(sys.argv[2]))
rclpy.init()
node = rclpy.create_node("lspp_probe")
state = {"q": Q_READY.copy(), "status": "", "traj": None, "commands": []}

def on_command(msg):  # a fake arm: it is wherever the last command sent it
    state["q"] = np.asarray(msg.position[:7], dtype=float)
    state["commands"].append(state["q"].tolist())

def on_status(msg):
    s = msg.status[0]
    state["status"] = s.message + " " + " ".join(f"{kv.key}={kv.value}" for kv in s.values)

def on_traj(msg):
    state["traj"] = trajectory_to_arrays(msg)[0].tolist()

node.create_subscription(JointState, "joint_command", on_command, 10)
node.create_subscription(DiagnosticArray, "planner/status", on_status, 10)
node.create_subscription(JointTrajectory, "planner/trajectory", on_traj, 10)
joints = node.create_publisher(JointState, "joint_states", 10)
node.create_timer(0.05, lambda: joints.publish(q_to_joint_state(state["q"], stamp=node.get_clock().now().to_msg())))
obstacles = node.create_publisher(MarkerArray, "obstacles", 10)
goal_pub = node.create_publisher(PoseStamped, "goal_pose", 10)

def spin_until(cond, timeout):
    end = time.monotonic() + timeout
    while not cond() and time.monotonic() < end:
        rclpy.spin_once(node, timeout_sec=0.05)
    return cond()

out = {}
assert spin_until(lambda: "mode=" in state["status"], 120.0), "no planner status"
out["before"] = state["status"]
assert spin_until(lambda: obstacles.get_subscription_count() > 0, 10.0), "planner not subscribed to obstacles"
obstacles.publish(cylinders_to_marker_array(cylinders, ns="test"))
spin_until(lambda: "mode=lspp" in state["status"], 10.0)
out["lspp"] = state["status"]

goal = target_to_pose_stamped(goal_position, np.array([1.0, 0.0, 0.0, 0.0]))  # orientation ignored by LSPP
client = node.create_client(GetPlan, "planner/plan")
assert client.wait_for_service(timeout_sec=10.0), "no planner/plan service"
future = client.call_async(GetPlan.Request(goal=goal))
rclpy.spin_until_future_complete(node, future, timeout_sec=60.0)
positions = path_to_arrays(future.result().plan)[0]
out["plan_end"] = positions[-1].tolist() if len(positions) else None
spin_until(lambda: state["traj"] is not None, 5.0)
out["plan_q"] = state["traj"]

state["commands"].clear()
goal_pub.publish(goal)
panda = load_panda()
reached = lambda: np.linalg.norm(panda.fk(state["q"]).translation - goal_position) < 0.015
out["closed_loop_reached"] = bool(spin_until(reached, 30.0))
out["closed_loop_status"] = state["status"]
out["commands"] = state["commands"]

bad = cylinders_to_marker_array(cylinders, ns="test")
bad.markers[0].pose.position.x = float("nan")
obstacles.publish(bad)
spin_until(lambda: "obstacles refused" in state["status"], 5.0)
out["after_nan"] = state["status"]
obstacles.publish(MarkerArray(markers=[Marker(action=Marker.DELETEALL)]))
spin_until(lambda: "mode=amp_ls" in state["status"], 5.0)
out["after_clear"] = state["status"]
print("RESULT " + json.dumps(out), flush=True)
"""


@pytest.fixture(scope="module")
def lspp_checkpoint(tmp_path_factory) -> str:
    """ "" (the shipped classifier) when it is in the repo, else the stem of a quickly trained one (~20 s)."""
    from latent_planner_ros.models.cylinder_classifier import shipped_classifier_path

    if shipped_classifier_path().with_suffix(".safetensors").exists():
        return ""
    out = tmp_path_factory.mktemp("lspp")
    args = ["--iterations", "300", "--samples", "4000", "--val-samples", "1000"]
    cmd = [sys.executable, "-m", "latent_planner_ros", "train", "lspp", *args, "--data", str(out / "data")]
    subprocess.run([*cmd, "--out", str(out / "run")], cwd=REPO, check=True, capture_output=True, timeout=300)
    return str(out / "run" / "best")


@pytest.mark.ros
@pytest.mark.slow
def test_planner_node_switches_to_lspp_on_cylinder_markers(lspp_checkpoint):
    """Cylinder markers switch the node to LSPP (no scene needed); plans and the closed loop avoid the cylinder;
    a NaN marker is refused; DELETEALL returns to AMP-LS, which holds for its missing scene as before."""
    from latent_planner_ros.data.cylinders import cylinder_scene
    from latent_planner_ros.data.labels import CollisionLabeler
    from latent_planner_ros.robot.limits import Q_READY
    from latent_planner_ros.robot.panda import load_panda

    # the cylinder blocks the direct joint-space motion from the ready pose to a configuration at the goal
    cylinders = [[0.4, -0.15, 0.6, 0.05]]
    goal_q = Q_READY + np.array([-0.9, 0.35, 0.0, 0.25, 0.0, -0.1, 0.0])
    goal = load_panda().fk(goal_q).translation.tolist()
    labeler = CollisionLabeler(cylinder_scene(np.array(cylinders)))
    assert labeler.label(np.linspace(Q_READY, goal_q, 50)).any() and not labeler.label(goal_q[None]).any()
    env = dict(os.environ, PYTHONUNBUFFERED="1")
    params = ["--params-file", "config/planner.yaml", "-p", "status_rate_hz:=10.0", "-p", "enabled:=true"]
    if lspp_checkpoint:
        params += ["-p", f"lspp_checkpoint:={lspp_checkpoint}"]
    planner = _run("planner", params, env)
    try:
        probe = subprocess.run(
            [sys.executable, "-c", LSPP_PROBE, json.dumps(cylinders), json.dumps(goal)],
            cwd=REPO,
            env=env,
            capture_output=True,
            text=True,
            timeout=240,
        )
    finally:
        logs = _stop([planner])
    line = next((x for x in probe.stdout.splitlines() if x.startswith("RESULT ")), None)
    assert line, f"probe failed:\n{probe.stdout}\n{probe.stderr[-3000:]}\n{logs}"
    out = json.loads(line[len("RESULT ") :])
    assert "mode=amp_ls" in out["before"], out["before"]
    assert "mode=lspp (1 cylinder; goals: position only)" in out["lspp"], out["lspp"]
    assert out["plan_end"] is not None and np.linalg.norm(np.subtract(out["plan_end"], goal)) < 0.0101, out
    assert not labeler.label(np.array(out["plan_q"])).any(), "the plan touches the cylinder"
    assert out["commands"] and not labeler.label(np.array(out["commands"])).any(), "a command touches the cylinder"
    assert out["closed_loop_reached"], out["closed_loop_status"]
    assert "scene" not in out["closed_loop_status"].split(" mode=")[0], out["closed_loop_status"]  # no hold for it
    assert "obstacles refused" in out["after_nan"] and "NaN" in out["after_nan"], out["after_nan"]
    assert "mode=lspp (1 cylinder" in out["after_nan"], out["after_nan"]  # the last valid set is kept
    assert "mode=amp_ls" in out["after_clear"] and "scene never received" in out["after_clear"], out["after_clear"]
    assert planner.returncode == 0, logs

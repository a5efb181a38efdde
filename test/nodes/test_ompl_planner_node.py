"""The ompl_planner node as a process, with the sim: GetPlan, execution, refused goals, clouds and parameters."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
import yaml

from latent_planner_ros.nodes.ompl_planner_config import OmplPlannerNodeConfig
from latent_planner_ros.params.config import ConfigError, from_params, to_params

REPO = Path(__file__).resolve().parents[2]

PROBE = r"""
import json, time
import numpy as np
import rclpy
from builtin_interfaces.msg import Time
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from nav_msgs.srv import GetPlan
from rcl_interfaces.msg import Parameter, ParameterType, ParameterValue
from rcl_interfaces.srv import SetParameters
from sensor_msgs.msg import JointState, PointCloud2, PointField
from trajectory_msgs.msg import JointTrajectory
from latent_planner_ros.robot.limits import Q_MAX, Q_MIN, Q_READY, V_MAX
from latent_planner_ros.robot.panda import load_panda
from latent_planner_ros.robot.rotations import matrix_to_quat
from msg_adapters import joint_state_to_q, target_to_pose_stamped, trajectory_to_execution

rclpy.init()
node = rclpy.create_node("ompl_probe")
state = {"q": None, "violations": [], "commands": 0, "status": [], "traj_stamps": []}
state.update(status_values=[], results=[])

def on_joints(msg):
    state["q"] = joint_state_to_q(msg)[0]

def on_execution(msg):  # the plan sent once on joint_trajectory: inside the joint limits, at most 0.5 V_MAX
    state["commands"] += 1
    t, q_cmd, dq, _ = trajectory_to_execution(msg)
    if not np.all(np.isfinite(q_cmd)) or np.any(q_cmd < Q_MIN - 1e-6) or np.any(q_cmd > Q_MAX + 1e-6):
        state["violations"].append("out of limits")
    elif dq is None or np.any(np.abs(dq) > 0.5 * V_MAX + 1e-9):
        state["violations"].append("no velocities or too fast")

def on_status(msg):
    for s in msg.status:
        state["status"].append(s.message + " " + " ".join(f"{kv.key}={kv.value}" for kv in s.values))
        state["status_values"].append({kv.key: kv.value for kv in s.values})

def on_result(msg):
    state["results"].append([ord(msg.level), msg.name, msg.message, {kv.key: kv.value for kv in msg.values}])

node.create_subscription(JointState, "joint_states", on_joints, 10)
node.create_subscription(JointTrajectory, "joint_trajectory", on_execution, 10)
node.create_subscription(DiagnosticArray, "ompl_planner/status", on_status, 10)
node.create_subscription(DiagnosticStatus, "ompl_planner/plan_result", on_result, 10)
node.create_subscription(JointTrajectory, "ompl_planner/trajectory", lambda m: state["traj_stamps"].append(
    (m.header.stamp.sec, m.header.stamp.nanosec)), 10)
cloud_pub = node.create_publisher(PointCloud2, "camera/points", 10)

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
client = node.create_client(GetPlan, "ompl_planner/plan")
assert client.wait_for_service(timeout_sec=60.0), "no ompl_planner/plan service"

def plan(pose, tolerance=0.0):
    future = client.call_async(GetPlan.Request(goal=pose, tolerance=tolerance))
    rclpy.spin_until_future_complete(node, future, timeout_sec=60.0)
    return future.result().plan

def status_has(text, timeout=5.0):
    return spin_until(lambda: any(text in s for s in state["status"]), timeout)

deadline = time.monotonic() + 30.0  # the first cloud may still be on its way
t0 = time.monotonic()
path = plan(goal, 0.01)
while not path.poses and time.monotonic() < deadline:
    spin_until(lambda: False, 1.0)
    t0 = time.monotonic()
    path = plan(goal, 0.01)
out["plan_s"] = time.monotonic() - t0
out["plan_len"] = len(path.poses)
if path.poses:
    p = path.poses[-1].pose.position
    out["plan_end_err"] = float(np.linalg.norm(np.array([p.x, p.y, p.z]) - tf.translation))
    stamp = (path.header.stamp.sec, path.header.stamp.nanosec)
    out["traj_stamp_matches"] = spin_until(lambda: stamp in state["traj_stamps"], 5.0)

# execution: the sim follows the trajectory sent on joint_trajectory
def tcp_err():
    return float(np.linalg.norm(panda.fk(state["q"]).translation - tf.translation))
t0 = time.monotonic()
out["executed"] = spin_until(lambda: tcp_err() < 0.01, 40.0)
out["execute_s"] = time.monotonic() - t0
out["final_err"] = tcp_err()
out["commands"] = state["commands"]
out["violations"] = state["violations"][:5]

# refusals: a NaN goal, an unreachable goal, a malformed cloud; the node answers and keeps running
bad = target_to_pose_stamped(tf.translation, quat)
bad.pose.position.x = float("nan")
out["nan_plan_len"] = len(plan(bad).poses)
out["status_nan"] = status_has("plan refused")
far = target_to_pose_stamped(np.array([3.0, 0.0, 0.5]), quat)
out["far_plan_len"] = len(plan(far).poses)
out["status_far"] = status_has("no IK solution")
broken = PointCloud2(height=1, width=2, point_step=4, row_step=8, data=bytes(8))
broken.header.frame_id = "world"
broken.fields = [PointField(name="x", offset=0, datatype=PointField.FLOAT32, count=1)]
cloud_pub.publish(broken)
out["status_cloud"] = status_has("camera/points refused")

def with_result(pose, tolerance=0.0):  # (waypoints returned, the request's plan_result or None)
    n = len(state["results"])
    length = len(plan(pose, tolerance).poses)
    spin_until(lambda: len(state["results"]) > n, 5.0)
    return length, state["results"][n] if len(state["results"]) > n else None

# refused tolerances, then a successful plan clears last_error; every request answers on plan_result
out["neg_tol_len"], out["neg_tol_result"] = with_result(goal, -0.01)
out["nan_tol_len"], out["nan_tol_result"] = with_result(goal, float("nan"))
spin_until(lambda: "tolerance" in state["status_values"][-1].get("last_error", ""), 5.0)
out["last_error_before"] = state["status_values"][-1].get("last_error")
stamped = target_to_pose_stamped(tf.translation, quat, stamp=Time(sec=7, nanosec=5))
out["replan_len"], out["replan_result"] = with_result(stamped, 0.01)
out["still_plans"] = out["replan_len"] > 0
n = len(state["status_values"])
spin_until(lambda: len(state["status_values"]) > n, 5.0)
out["last_error_after"] = state["status_values"][-1].get("last_error") if len(state["status_values"]) > n else "-"

# a bad parameter is refused with a reason
params = node.create_client(SetParameters, "ompl_planner/set_parameters")
assert params.wait_for_service(timeout_sec=10.0)
value = ParameterValue(type=ParameterType.PARAMETER_STRING, string_value="rrt_sharp")
future = params.call_async(SetParameters.Request(parameters=[Parameter(name="ompl.planner", value=value)]))
rclpy.spin_until_future_complete(node, future, timeout_sec=10.0)
answer = future.result().results[0]
out["param_refused"] = not answer.successful and "planner must be one of" in answer.reason
print("RESULT " + json.dumps(out), flush=True)
"""


def _flatten(tree: dict, prefix: str = "") -> dict:
    out = {}
    for key, value in tree.items():
        out.update(_flatten(value, f"{prefix}{key}.") if isinstance(value, dict) else {prefix + key: value})
    return out


def test_yaml_matches_the_config_and_bad_values_are_refused_by_name():
    params = _flatten(
        yaml.safe_load((REPO / "config" / "ompl_planner.yaml").read_text())["ompl_planner"]["ros__parameters"]
    )
    assert set(params) == set(to_params(OmplPlannerNodeConfig()))
    assert from_params(OmplPlannerNodeConfig, params) == OmplPlannerNodeConfig()
    for name, value, message in [
        ("limits.jerk_scale", 0.0, "jerk_scale"),
        ("execute", "yes", "execute"),
        ("ompl.planner", "rrt_sharp", "planner must be one of"),
        ("ompl.octree_resolution", -0.02, "octree_resolution"),
        ("ompl.ik.max_iters", 0, "ik.max_iters"),
        ("ompl.nonsense", 1, "unknown parameter"),
    ]:
        with pytest.raises((ConfigError, ValueError), match=message):
            from_params(OmplPlannerNodeConfig, {name: value})


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


def _check_plan_results(out: dict, name: str) -> None:
    """The plan_result (level, name, message, values) of the refused tolerances and of the successful plan."""
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


@pytest.mark.ros
@pytest.mark.slow
def test_ompl_planner_node_plans_executes_and_refuses_bad_input():
    env = dict(os.environ, PYTHONUNBUFFERED="1")
    sim = _run("sim", ["--params-file", "config/sim.yaml", "-p", "scenario:=empty"], env)
    planner = _run(
        "ompl_planner",
        ["--params-file", "config/ompl_planner.yaml", "-p", "use_sim_time:=true", "-p", "execute:=true"],
        env,
    )
    try:
        probe = subprocess.run(
            [sys.executable, "-c", PROBE], cwd=REPO, env=env, capture_output=True, text=True, timeout=240
        )
    finally:
        logs = _stop([sim, planner])
    line = next((x for x in probe.stdout.splitlines() if x.startswith("RESULT ")), None)
    assert line, f"probe failed:\n{probe.stdout}\n{probe.stderr[-3000:]}\n{logs}"
    out = json.loads(line[len("RESULT ") :])
    print(out)
    assert out["plan_len"] > 1 and out["plan_end_err"] < 0.01 and out["traj_stamp_matches"], out
    assert out["executed"] and out["commands"] > 0 and out["violations"] == [], (out, logs)
    assert out["nan_plan_len"] == 0 and out["status_nan"], out
    assert out["far_plan_len"] == 0 and out["status_far"], out
    assert out["status_cloud"] and out["still_plans"] and out["param_refused"], out
    _check_plan_results(out, "ompl_planner")
    assert planner.returncode == 0 and sim.returncode == 0, logs

"""Execution through joint_trajectory, with the sim as the JointTrajectoryController, as processes: nothing is
commanded without a goal; the sim follows the planner's segments with continuous velocity; every published
trajectory keeps the velocity, acceleration and jerk limits; a plan of ompl_planner executes through
joint_trajectory; the two planners never command at once (enabling one disables the other)."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest

from test.nodes.test_planner_node import REPO, _run, _stop

PROBE = r"""
import json, time
import numpy as np
import rclpy
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import PoseStamped
from nav_msgs.srv import GetPlan
from rcl_interfaces.msg import Parameter, ParameterType, ParameterValue
from rcl_interfaces.srv import SetParameters
from sensor_msgs.msg import JointState
from std_srvs.srv import SetBool
from trajectory_msgs.msg import JointTrajectory
from latent_planner_ros.planning.motion_limits import MotionLimits
from latent_planner_ros.robot.limits import Q_READY
from latent_planner_ros.robot.panda import load_panda
from latent_planner_ros.robot.rotations import matrix_to_quat
from msg_adapters import joint_state_to_q, target_to_pose_stamped, trajectory_to_execution

LIMITS = MotionLimits()  # the shipped limits.* of both planners
rclpy.init()
node = rclpy.create_node("execution_probe")
state = {"q": None, "joints": [], "segments": [], "commands": 0, "violations": [], "status": {}, "checked": {}}

def check(topic, msg):  # every trajectory within the velocity, acceleration and jerk limits
    state["checked"][topic] = state["checked"].get(topic, 0) + 1
    t, q, dq, ddq = trajectory_to_execution(msg)
    if dq is None or ddq is None:
        state["violations"].append(f"{topic}: no velocities or accelerations")
        return t
    jerk = np.abs(np.diff(ddq, axis=0)) / np.diff(t)[:, None]
    for name, value, bound in (("velocity", np.abs(dq), LIMITS.v_max), ("acceleration", np.abs(ddq), LIMITS.a_max),
                               ("jerk", jerk, LIMITS.j_max)):
        if np.any(value > bound * 1.001 + 1e-9):
            state["violations"].append(f"{topic}: {name} {float((value / bound).max()):.3f} of the limit")
    if np.any(dq[[0, -1]] != 0) and topic != "joint_trajectory":
        state["violations"].append(f"{topic}: not at rest at both ends")
    return t

def on_segment(msg):  # the planner samples its segments every 20 ms, ompl_planner its plans every 10 ms
    t = check("joint_trajectory", msg)
    source = "ompl_planner" if len(t) > 1 and t[1] - t[0] < 0.015 else "planner"
    state["segments"].append((time.monotonic(), source, float(t[-1])))

def on_joints(msg):
    q, dq = joint_state_to_q(msg)
    state["q"] = q
    state["joints"].append((msg.header.stamp.sec + msg.header.stamp.nanosec * 1e-9, dq.tolist()))

def on_status(name, msg):
    state["status"][name] = {kv.key: kv.value for kv in msg.status[0].values}

def on_command(msg):
    state["commands"] += 1

node.create_subscription(JointState, "joint_states", on_joints, 50)
node.create_subscription(JointTrajectory, "joint_trajectory", on_segment, 50)
node.create_subscription(JointState, "joint_command", on_command, 50)
for name in ("planner", "ompl_planner"):
    node.create_subscription(JointTrajectory, f"{name}/trajectory", lambda m, n=name: check(f"{n}/trajectory", m), 10)
    node.create_subscription(DiagnosticArray, f"{name}/status", lambda m, n=name: on_status(n, m), 10)
goal_pub = node.create_publisher(PoseStamped, "goal_pose", 10)

def spin_until(cond, timeout):
    end = time.monotonic() + timeout
    while not cond() and time.monotonic() < end:
        rclpy.spin_once(node, timeout_sec=0.02)
    return cond()

def call(srv, name, request, timeout=60.0):
    client = node.create_client(srv, name)
    assert client.wait_for_service(timeout_sec=120.0), f"no {name}"
    future = client.call_async(request)
    rclpy.spin_until_future_complete(node, future, timeout_sec=timeout)
    return future.result()

def set_execute(value):
    p = Parameter(name="execute", value=ParameterValue(type=ParameterType.PARAMETER_BOOL, bool_value=value))
    return call(SetParameters, "ompl_planner/set_parameters", SetParameters.Request(parameters=[p])).results[0]

panda = load_panda()
def pose_of(q):
    tf = panda.fk(q)
    return tf.translation, target_to_pose_stamped(tf.translation, matrix_to_quat(tf.rotation))
def tcp_err(position):
    return float(np.linalg.norm(panda.fk(state["q"]).translation - position))

out = {}
assert spin_until(lambda: state["q"] is not None and {"planner", "ompl_planner"} <= set(state["status"]), 180.0)
# 1. enabled, no goal: nothing is commanded
spin_until(lambda: False, 3.0)
out["idle_state"] = state["status"]["planner"].get("state")
out["idle_segments"], out["idle_commands"] = len(state["segments"]), state["commands"]
goal_a, pose_a = pose_of(Q_READY + np.array([0.5, 0.25, -0.2, 0.35, 0.1, -0.2, 0.3]))
out["planner_plan_len"] = len(call(GetPlan, "planner/plan", GetPlan.Request(goal=pose_a)).plan.poses)

# 2. a goal: the sim follows the planner's segments
n_joints = len(state["joints"])
goal_pub.publish(pose_a)
out["planner_reached"] = spin_until(lambda: tcp_err(goal_a) < 0.015, 60.0)
spin_until(lambda: False, 1.0)
out["closed_loop_joints"] = state["joints"][n_joints:]
out["closed_loop_sources"] = sorted({s for _, s, _ in state["segments"]})

# 3. ompl_planner's execute on: the planner is disabled; ompl_planner's plan executes through joint_trajectory
out["execute_on"] = set_execute(True).successful
out["planner_disabled"] = spin_until(lambda: state["status"]["planner"].get("state") == "disabled", 5.0)
out["owner_after_claim"] = state["status"]["planner"].get("execution_owner")
spin_until(lambda: False, 0.5)  # a segment in flight when the claim arrived
claim_commands, claim_segments = state["commands"], len(state["segments"])
goal_b, pose_b = pose_of(Q_READY)
plan = call(GetPlan, "ompl_planner/plan", GetPlan.Request(goal=pose_b)).plan
out["ompl_plan_len"] = len(plan.poses)
out["ompl_reached"] = spin_until(lambda: tcp_err(goal_b) < 0.01, 40.0)
spin_until(lambda: state["status"]["ompl_planner"].get("state") == "executed", 10.0)
out["ompl_state"] = state["status"]["ompl_planner"].get("state")
out["while_ompl"] = [s for _, s, _ in state["segments"][claim_segments:]]
out["planner_commands_while_ompl"] = state["commands"] - claim_commands

# 4. the planner enabled again: ompl_planner's execute turns off, its next plan is not executed
out["enable"] = call(SetBool, "planner/enable", SetBool.Request(data=True)).success
spin_until(lambda: state["status"]["ompl_planner"].get("execution_owner") == "/planner", 5.0)
n = len(state["segments"])
plan = call(GetPlan, "ompl_planner/plan", GetPlan.Request(goal=pose_a)).plan
out["second_ompl_plan_len"] = len(plan.poses)
out["planner_back"] = spin_until(lambda: tcp_err(goal_a) < 0.015, 60.0)
out["after_enable"] = sorted({s for _, s, _ in state["segments"][n:]})
out["ompl_status_after"] = state["status"]["ompl_planner"]
spin_until(lambda: False, 0.5)
out["violations"], out["checked"] = state["violations"][:5], state["checked"]
print("RESULT " + json.dumps(out), flush=True)
"""


@pytest.mark.ros
@pytest.mark.slow
def test_execution_through_joint_trajectory_one_source_at_a_time():
    import numpy as np

    from latent_planner_ros.planning.motion_limits import MotionLimits

    env = dict(os.environ, PYTHONUNBUFFERED="1")
    sim_time = ["-p", "use_sim_time:=true"]
    procs = [
        _run("sim", ["--params-file", "config/sim.yaml", "-p", "scenario:=empty"], env),
        _run(
            "planner",
            ["--params-file", "config/planner.yaml", *sim_time, "-p", "enabled:=true", "-p", "status_rate_hz:=10.0"]
            + ["-p", "amp_ls.collision_backend:=geometric"],
            env,
        ),
        _run(
            "ompl_planner", ["--params-file", "config/ompl_planner.yaml", *sim_time, "-p", "status_rate_hz:=10.0"], env
        ),
    ]
    try:
        probe = subprocess.run(
            [sys.executable, "-c", PROBE], cwd=REPO, env=env, capture_output=True, text=True, timeout=480
        )
    finally:
        logs = _stop(procs)
    line = next((x for x in probe.stdout.splitlines() if x.startswith("RESULT ")), None)
    assert line, f"probe failed:\n{probe.stdout}\n{probe.stderr[-3000:]}\n{logs}"
    out = json.loads(line[len("RESULT ") :])
    brief = {k: v for k, v in out.items() if k != "closed_loop_joints"}
    # no command without a goal
    assert out["idle_state"] == "idle" and out["idle_segments"] == 0 and out["idle_commands"] == 0, brief
    # the sim follows the planner's segments with continuous velocity: the measured joint velocity changes by at
    # most 2.5 times the acceleration limit over each 10 ms joint_states period (PD tracking and the real targets
    # on top of the reference; 10 Hz position targets reach about 10 rad/s^2 on every joint,
    # test/sim_bridge/test_sim_trajectory.py)
    assert out["planner_reached"] and out["closed_loop_sources"] == ["planner"], brief
    stamps = np.array([t for t, _ in out["closed_loop_joints"]])
    velocities = np.array([dq for _, dq in out["closed_loop_joints"]])
    keep = np.diff(stamps) > 0
    acceleration = np.abs(np.diff(velocities, axis=0))[keep] / np.diff(stamps)[keep, None]
    assert np.abs(velocities).max() > 0.1, "the arm did not move"
    assert np.all(acceleration.max(axis=0) <= 2.5 * MotionLimits().a_max), acceleration.max(axis=0)
    # two planners never command at once; ompl_planner's plan executes through joint_trajectory
    assert out["execute_on"] and out["planner_disabled"] and out["owner_after_claim"] == "/ompl_planner", brief
    assert out["planner_commands_while_ompl"] == 0 and out["while_ompl"] == ["ompl_planner"], brief
    assert out["ompl_plan_len"] > 1 and out["ompl_reached"] and out["ompl_state"] == "executed", brief
    assert out["enable"] and out["second_ompl_plan_len"] > 1 and out["planner_back"], brief
    assert out["after_enable"] == ["planner"] and out["ompl_status_after"]["executing"] == "False", brief
    assert "execute turned off: /planner claimed the arm" in logs, logs[-3000:]
    # every trajectory on joint_trajectory, planner/trajectory and ompl_planner/trajectory within the limits
    assert out["violations"] == [] and out["planner_plan_len"] > 1, brief
    assert set(out["checked"]) == {"joint_trajectory", "planner/trajectory", "ompl_planner/trajectory"}, brief
    assert all(p.returncode == 0 for p in procs), logs

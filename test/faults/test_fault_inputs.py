"""The faults the cases inject are refused (or accepted) by the planner's own code for the stated reason.

ROS-free except for message types: this pins the texts that test_fault_injection looks for on status/logs.
"""

import re

import numpy as np
import pytest

from latent_planner_ros.evaluation import fault_suite
from latent_planner_ros.evaluation.fault_inputs import (
    BOX_CENTRE,
    JOINT_STATE_FAULTS,
    bad_goals,
    box_cloud,
    goal_pose,
    malformed_clouds,
)
from latent_planner_ros.evaluation.fault_suite import plan_fault_suite
from latent_planner_ros.planning.closed_loop import ClosedLoopConfig, ClosedLoopController
from latent_planner_ros.planning.goal import Goal
from latent_planner_ros.robot.limits import Q_READY
from msg_adapters import AdapterError, cloud_to_xyz, joint_state_to_q, pose_stamped_to_target


def test_malformed_clouds_are_refused_with_their_reason_and_odd_ones_are_read():
    scene = box_cloud()
    n = scene.width
    for name, (msg, text) in malformed_clouds(scene).items():
        if text:
            with pytest.raises(AdapterError, match=re.escape(text)):
                cloud_to_xyz(msg)
        else:
            used = len(cloud_to_xyz(msg))
            assert used == {"cloud_nan_points": 0, "cloud_inf_points": n - (n + 2) // 3, "cloud_zero_points": 0}[name]


def test_the_box_cloud_fills_the_box():
    pts = cloud_to_xyz(box_cloud())
    assert np.min(np.linalg.norm(pts - BOX_CENTRE, axis=1)) < 0.01  # points inside, not only on the faces
    surface = cloud_to_xyz(box_cloud(surface=True))
    assert np.min(np.linalg.norm(surface - BOX_CENTRE, axis=1)) > 0.05


def test_bad_goals_are_refused_for_their_reason():
    ctrl = ClosedLoopController.__new__(ClosedLoopController)  # only the goal checks, no planner needed
    ctrl.config, ctrl._cloud = ClosedLoopConfig(), cloud_to_xyz(box_cloud()).astype(float)
    ctrl._eyes = None  # cameras unknown: the clearance rule alone
    for _name, (msg, text) in bad_goals(goal_pose("A")).items():
        try:
            target = pose_stamped_to_target(msg)
        except AdapterError as err:
            assert text in str(err)
            continue
        ok, reason = ctrl.check_goal(Goal(target.position, target.rotation))
        assert not ok and text in reason
    for name in ("A", "B"):
        target = pose_stamped_to_target(goal_pose(name))
        assert ctrl.check_goal(Goal(target.position, target.rotation)) == (True, "")


def test_joint_state_faults_are_refused_or_read_correctly():
    q = Q_READY + 0.1
    ctrl = ClosedLoopController.__new__(ClosedLoopController)
    ctrl._q, ctrl._q_time = None, -np.inf
    for _name, (fault, text) in JOINT_STATE_FAULTS.items():
        msg = fault(q)
        try:
            got, _ = joint_state_to_q(msg)
        except AdapterError as err:
            assert text and text in str(err)
            continue
        accepted, reason = ctrl.set_joint_state(got, 0.0)
        if text:
            assert not accepted and text in reason
        else:
            assert accepted
            np.testing.assert_allclose(got, q)


def test_fault_suites_without_the_sim_leave_it_out_and_pin_the_backend():
    plan = plan_fault_suite("geometric")
    assert plan.nodes == ("planner",) and not plan.with_sim
    assert "amp_ls.collision_backend:=geometric" in plan.params["planner"]
    with_sim = plan_fault_suite("geometric", with_sim=True)
    assert with_sim.nodes == ("sim", "planner") and "scenario:=empty" in with_sim.params["sim"]


def test_the_configured_learned_backend_runs_the_scene_encoder_when_its_weights_exist(monkeypatch, tmp_path):
    weights = tmp_path / "collision.safetensors"
    monkeypatch.setattr(fault_suite, "configured_planner", lambda: ("learned", ""))
    monkeypatch.setattr(fault_suite, "collision_weights", lambda checkpoint="": weights)
    plan = plan_fault_suite("configured")
    assert plan.backend == "geometric" and plan.nodes == ("planner",) and "not installed" in plan.notes[0]
    weights.write_bytes(b"")
    plan = plan_fault_suite("configured", with_sim=True)
    assert plan.backend == "learned" and plan.nodes == ("sim", "scene_encoder", "planner")
    assert "amp_ls.collision_backend:=learned" in plan.params["planner"]

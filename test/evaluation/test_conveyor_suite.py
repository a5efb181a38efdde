"""The conveyor suite's processes: which nodes, which parameters, the planner's goal remapping. No process started."""

from __future__ import annotations

import pytest

from latent_planner_ros.evaluation import conveyor_suite
from latent_planner_ros.evaluation.conveyor_suite import plan_suite
from latent_planner_ros.processes.node_suite import SuiteError, node_argv, suite_specs


def _argv(plan, node: str) -> list[str]:
    specs = suite_specs(plan.nodes, plan.params, env={}, ros_args=plan.ros_args)
    return list(next(s for s in specs if s.name == node).argv)


def test_node_argv_appends_ros_args_after_the_parameters():
    argv = node_argv("planner", ["enabled:=false"], None, True, ros_args=("-r", "goal_pose:=target_pose"))
    i = argv.index("--ros-args")
    assert argv[i:] == (
        "--ros-args",
        "-p",
        "use_sim_time:=true",
        "-p",
        "enabled:=false",
        "-r",
        "goal_pose:=target_pose",
    )


def test_geometric_suite_leaves_the_scene_encoder_out_and_remaps_the_goal():
    plan = plan_suite("geometric", seed=4, real_time_factor=1.0)
    assert plan.nodes == ("sim", "planner")
    assert any("scene_encoder not started" in n for n in plan.notes)
    planner = _argv(plan, "planner")
    assert planner[-2:] == ["-r", "goal_pose:=target_pose"]
    assert "enabled:=false" in planner  # the trial enables it once the scene is reset
    sim = _argv(plan, "sim")
    assert {"scenario:=conveyor", "seed:=4", "real_time_factor:=1.0"} <= set(sim)
    assert "use_sim_time:=true" in sim and "use_sim_time:=true" in planner


def test_learned_default_without_weights_falls_back_to_geometric(monkeypatch, tmp_path):
    monkeypatch.setattr(conveyor_suite, "configured_planner", lambda: ("learned", ""))
    monkeypatch.setattr(conveyor_suite, "collision_weights", lambda checkpoint="": tmp_path / "collision.safetensors")
    plan = plan_suite()
    assert plan.backend == "geometric" and plan.configured_backend == "learned"
    assert plan.nodes == ("sim", "planner")
    assert "amp_ls.collision_backend:=geometric" in plan.params["planner"]
    assert any("not installed" in n for n in plan.notes)
    with pytest.raises(SuiteError, match="does not exist"):
        plan_suite("learned")


def test_learned_with_weights_runs_the_scene_encoder(monkeypatch, tmp_path):
    weights = tmp_path / "collision.safetensors"
    weights.write_bytes(b"")
    monkeypatch.setattr(conveyor_suite, "configured_planner", lambda: ("learned", ""))
    monkeypatch.setattr(conveyor_suite, "collision_weights", lambda checkpoint="": weights)
    plan = plan_suite()
    assert plan.backend == "learned" and plan.nodes == ("sim", "scene_encoder", "planner")
    assert not any("collision_backend" in p for p in plan.params["planner"])  # the config's own choice
    assert plan.notes == ()
    geometric = plan_suite("geometric")
    assert "amp_ls.collision_backend:=geometric" in geometric.params["planner"]


def test_planner_parameters_can_be_set_for_a_run():
    plan = plan_suite("geometric", planner_set=["closed_loop.goal_lead_s=0.5", " amp_ls.lr = 0.1"])
    planner = _argv(plan, "planner")
    assert "closed_loop.goal_lead_s:=0.5" in planner and "amp_ls.lr:=0.1" in planner
    for bad in ("goal_lead_s", "=1", "a=", "a:=1"):
        with pytest.raises(SuiteError, match="NAME=VALUE"):
            plan_suite("geometric", planner_set=[bad])

"""The simulator core without ROS: stepping every scenario, tracking, limits, holding, contacts, reset."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from latent_planner_ros.robot.limits import Q_MAX, Q_MIN, Q_READY, V_MAX
from latent_planner_ros.robot.panda import load_panda
from sim_bridge.scenario import Scenario, scenario_from_dict

SHIPPED = sorted(p.stem for p in (Path(__file__).resolve().parents[2] / "config" / "scenarios").glob("*.yaml"))

STEPS_PER_COMMAND = 50  # 10 Hz commands at the 2 ms physics step


def step_commands(sim, targets, hold_s: float = 0.0):
    """Send each target for 0.1 s, then hold the last for hold_s; returns q (n, 7) and dq (n, 7) per step."""
    qs, dqs = [], []
    steps = [(t, STEPS_PER_COMMAND) for t in targets] + [(None, round(hold_s / sim.config.timestep))]
    for target, n in steps:
        if target is not None:
            assert sim.set_command(target).accepted
        for _ in range(n):
            sim.step()
            qs.append(sim.data.qpos[:7].copy())
            dqs.append(sim.data.qvel[:7].copy())
    return np.array(qs), np.array(dqs)


@pytest.mark.parametrize("name", SHIPPED)
def test_every_scenario_steps_under_random_commands_without_warnings(make_sim, name):
    rng = np.random.default_rng(1)
    sim = make_sim(name, seed=1)
    targets = rng.uniform(Q_MIN, Q_MAX, size=(10, 7))  # far, random targets: 1 s in all
    qs, dqs = step_commands(sim, targets)
    assert sim.warnings() == {}
    assert np.all(np.isfinite(qs)) and np.all(np.isfinite(dqs))
    assert np.all(qs >= Q_MIN - 0.01) and np.all(qs <= Q_MAX + 0.01)
    assert sim.data.time == pytest.approx(1.0)
    assert sim.point_cloud().shape[1] == 3


def test_tracks_10hz_targets_smoothly_and_settles_within_1mm(make_sim):
    """A 2 s path streamed at 10 Hz, then 0.5 s without commands: < 1 mm from the final target's pose,
    no overshoot (each joint approaches its final value without crossing it by more than 0.1 mrad)."""
    panda = load_panda()
    rng = np.random.default_rng(2)
    sim = make_sim("empty")
    for _ in range(3):
        sim.reset()
        goal = np.clip(Q_READY + rng.uniform(-0.8, 0.8, size=7), Q_MIN + 0.1, Q_MAX - 0.1)
        s = np.linspace(0, 1, 21)[1:]
        path = Q_READY + (0.5 - 0.5 * np.cos(np.pi * s))[:, None] * (goal - Q_READY)
        qs, dqs = step_commands(sim, path, hold_s=0.5)
        error_mm = 1000 * np.linalg.norm(sim.get_state().tcp_position - panda.fk(goal).translation)
        assert error_mm < 1.0
        hold = qs[len(path) * STEPS_PER_COMMAND :] - goal
        sign = np.sign(hold[0])
        assert np.all(hold * sign > -1e-4), "overshoot: the arm crossed its target"
        assert np.all(np.abs(dqs) <= V_MAX)


def test_velocity_limit_holds_for_far_targets(make_sim):
    rng = np.random.default_rng(3)
    sim = make_sim("empty")
    _, dqs = step_commands(sim, rng.uniform(Q_MIN, Q_MAX, size=(15, 7)))
    ratio = np.abs(dqs) / V_MAX
    assert ratio.max() <= 1.0, f"joint speed reached {ratio.max():.3f} x V_MAX"
    assert ratio.max() > 0.5  # the test did move fast


def test_holds_without_commands_against_gravity(make_sim, rng):
    for q in rng.uniform(Q_MIN + 0.2, Q_MAX - 0.2, size=(3, 7)):
        sim = make_sim("empty", initial_q=tuple(q))
        tcp0 = sim.get_state().tcp_position
        sim.step(1000)  # 2 s, no command
        assert np.linalg.norm(sim.get_state().tcp_position - tcp0) < 1e-4


BLOCK = {"name": "block", "type": "box", "half_extents": [0.05, 0.15, 0.05], "position": [0.5, 0.0, 0.4]}


def test_commanding_the_arm_into_an_object_sets_in_collision(make_sim):
    sim = make_sim(scenario_from_dict({"name": "block", "objects": [BLOCK]}))
    assert not sim.in_collision() and not sim.collided_since_last_check()
    reach = Q_READY + np.array([0.0, 0.7, 0.0, 0.5, 0.0, 0.0, 0.0])  # hand forward and down into the block
    touched = []
    for _ in range(20):
        sim.set_command(reach)
        sim.step(STEPS_PER_COMMAND)
        touched.append(sim.collided_since_last_check())
    assert any(touched)
    assert any(scene == "object/block" for _robot, scene in sim.contacts())
    sim.reset()
    assert not sim.in_collision()


def test_the_table_counts_as_a_collision(make_sim):
    sim = make_sim("empty")
    down = np.array([0.0, 1.4, 0.0, -0.8, 0.0, 1.4, 0.785])  # TCP 6 cm below the table top
    for _ in range(20):
        sim.set_command(down)
        sim.step(STEPS_PER_COMMAND)
        if sim.collided_since_last_check():
            break
    assert "table" in {scene for _robot, scene in sim.contacts()}


@pytest.mark.parametrize("seed", range(5))
def test_generated_scenes_leave_the_ready_pose_free(make_sim, seed):
    for name in ("tabletop", "conveyor"):
        sim = make_sim(name, seed=seed)
        sim.step(500)
        assert not sim.collided_since_last_check(), sim.contacts()


def test_conveyor_objects_and_target_move(make_sim):
    sim = make_sim("conveyor", seed=0)
    target0, _ = sim.target_pose()
    obstacle = sim.model.body("object/obstacle").mocapid[0]
    y0 = sim.data.mocap_pos[obstacle][1]
    sim.step(500)  # 1 s at 0.05 m/s
    target1, quat = sim.target_pose()
    np.testing.assert_allclose(quat, [1, 0, 0, 0])
    moved = (target1 - target0)[1]
    assert moved == pytest.approx(0.05, abs=1e-6) or moved < -0.5  # moved, or wrapped round
    dy = sim.data.mocap_pos[obstacle][1] - y0
    assert dy == pytest.approx(0.05, abs=1e-6) or dy < -0.5


def test_reset_restores_the_initial_state_and_swaps_scenes(make_sim):
    sim = make_sim("tabletop", seed=4)
    sim.set_command(Q_READY + 0.3)
    sim.step(200)
    sim.reset()
    np.testing.assert_allclose(sim.get_state().q, Q_READY)
    assert sim.data.time == 0.0
    sim.reset(Scenario(name="nothing"))
    assert sim.scenario.name == "nothing" and sim.model.nmocap == 0

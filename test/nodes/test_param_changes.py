"""Every runtime parameter change of planner, ompl_planner, scene_encoder and sim is applied or refused: each
parameter in turn is set to another value of its type; the set either fails with a reason that names the full
dotted parameter, or the node runs on the new value (its config, the objects built from it, the timers of its
rates; the sim's at the next sim/reset, as documented), and the old value is set back."""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import replace

import pytest
import rclpy
from rclpy.executors import SingleThreadedExecutor
from rclpy.parameter import Parameter

from latent_planner_ros.params.config import to_params
from latent_planner_ros.params.specs import ParamSpec, param_specs

pytestmark = [pytest.mark.ros, pytest.mark.slow]


def changed_value(spec: ParamSpec):
    """Another value than spec.value of spec's type: inside its range where it has one (the middle, else an end)."""
    v, r = spec.value, spec.range
    if spec.type == "bool":
        return not v
    if spec.type == "string":
        return v + "_x" if v else "x"
    if spec.type == "double[]":
        return [x + 0.01 for x in v] if v else [0.5]
    if spec.type == "string[]":
        return [*v, "x"]
    if spec.type == "integer[]":
        return [x + 1 for x in v] if v else [1]
    number = int if spec.type == "integer" else float
    if r is not None and r.bounded:
        for candidate in ((r.low + r.high) / 2, r.high, r.low):
            candidate = number(candidate)
            inside = (candidate > r.low if r.open_low else candidate >= r.low) and (
                candidate < r.high if r.open_high else candidate <= r.high
            )
            if inside and candidate != v:
                return candidate
    if r is not None:  # "> a" or ">= a"
        return number(v * 1.5) if v > r.low else number(r.low + 1)
    return number(v + 1) if spec.type == "integer" else v * 1.1 + 0.1


def _plain(value):
    return list(value) if not isinstance(value, str | bytes) and hasattr(value, "__len__") else value


def same(a, b) -> bool:
    if isinstance(a, float | int) and isinstance(b, float | int) and not isinstance(a, bool):
        return math.isclose(a, b, rel_tol=1e-9, abs_tol=1e-12)
    if isinstance(a, list | tuple) and isinstance(b, list | tuple):
        return len(a) == len(b) and all(same(x, y) for x, y in zip(a, b, strict=True))
    return a == b


def named(name: str, reason: str) -> bool:
    """The reason names the parameter as the nodes' refusals do: `name: ...`, `name must ...`, rclpy's range and
    read-only messages."""
    forms = (f"{name}: ", f"{name} must ", f"Parameter {name} out of range", f"read-only parameter: {name}.")
    return reason.startswith(forms[:2]) or any(f in reason for f in forms[2:])


def ticks_at(timer, rate_hz: float) -> bool:
    """The timer's period is 1 / rate_hz (to the nanosecond rclpy truncates to)."""
    return abs(timer.timer_period_ns - 1e9 / rate_hz) <= 1.0


def walk(node, executor, specs: dict[str, ParamSpec], current: Callable[[str], object], settle=None) -> dict:
    """Set each parameter to another value; check the outcome with `current(name)` (the value the node runs on)
    after `settle()`; set the old value back. {name: "applied" | "refused: reason"}; AssertionError on a set
    that was neither applied nor refused by name."""
    outcomes = {}
    for name, spec in specs.items():
        old = _plain(node.get_parameter(name).value)
        new = changed_value(replace(spec, value=old))
        r = node.set_parameters([Parameter(name, value=new)])[0]
        if not r.successful:
            assert named(name, r.reason), f"{name} = {new!r} refused without its name: {r.reason!r}"
            outcomes[name] = f"refused: {r.reason}"
            continue
        if settle is not None:
            settle()
        assert same(current(name), new), f"{name} = {new!r} accepted but the node runs on {current(name)!r}"
        outcomes[name] = "applied"
        r = node.set_parameters([Parameter(name, value=old)])[0]
        assert r.successful, f"{name}: setting the old value {old!r} back was refused: {r.reason}"
        if settle is not None:
            settle()
    return outcomes


def spin_until(executor, cond, timeout_s=30.0) -> bool:
    end = time.monotonic() + timeout_s
    while not cond() and time.monotonic() < end:
        executor.spin_once(timeout_sec=0.02)
    return cond()


@pytest.fixture
def ros():
    nodes = []

    def start(factory, *args):
        rclpy.init(args=["--ros-args", *args])
        node = factory()
        executor = SingleThreadedExecutor()
        executor.add_node(node)
        nodes.append((node, executor))
        return node, executor

    try:
        yield start
    finally:
        for node, executor in nodes:
            executor.shutdown()
            if hasattr(node, "close"):
                node.close()
            node.destroy_node()
        rclpy.try_shutdown()


def test_planner(ros):
    from latent_planner_ros.nodes.planner import PlannerNode
    from latent_planner_ros.nodes.planner_config import RANGES, READ_ONLY, PlannerNodeConfig

    node, executor = ros(PlannerNode, "-p", "amp_ls.collision_backend:=geometric")

    def settle():  # the rebuild of the planners is swapped in at a tick
        assert spin_until(executor, lambda: not node._rebuild.pending), "a rebuild never finished"

    def current(name):
        c = node.config
        loop, amp_ls = c.closed_loop_config(), c.amp_ls_config()
        assert node.modes.amp_ls.config == loop and node.modes.lspp.config == loop
        assert node.modes.amp_ls.planner.config == amp_ls and node.plan_planner.config == amp_ls
        assert node.modes.lspp.planner.config == c.lspp_config()
        assert ticks_at(node._tick_timer, c.closed_loop.rate_hz)
        assert ticks_at(node._status_timer, c.status_rate_hz)
        assert node.fusion.max_age_s == c.cloud_max_age_s
        return to_params(c)[name]

    outcomes = walk(node, executor, param_specs(PlannerNodeConfig(), RANGES, READ_ONLY), current, settle)
    assert outcomes["amp_ls.lr"] == "applied" and outcomes["closed_loop.rate_hz"] == "applied"
    assert outcomes["amp_ls.preset"].startswith("refused: amp_ls.preset must be one of")  # an unknown preset
    assert outcomes["cloud_topics"].startswith("refused") and outcomes["tuning_file"].startswith("refused")


def test_ompl_planner(ros):
    from latent_planner_ros.nodes.ompl_planner import OmplPlannerNode
    from latent_planner_ros.nodes.ompl_planner_config import RANGES, READ_ONLY, OmplPlannerNodeConfig

    node, executor = ros(OmplPlannerNode)

    def current(name):
        assert node.planner.config == node.config.ompl
        assert ticks_at(node._status_timer, node.config.status_rate_hz)
        assert node.fusion.max_age_s == node.config.cloud_max_age_s
        return to_params(node.config)[name]

    outcomes = walk(node, executor, param_specs(OmplPlannerNodeConfig(), RANGES, READ_ONLY), current)
    assert outcomes["status_rate_hz"] == "applied" and outcomes["execute"] == "applied"


def test_scene_encoder(ros):
    from latent_planner_ros.nodes.scene_encoder import SceneEncoderNode
    from latent_planner_ros.nodes.scene_encoder_config import RANGES, READ_ONLY, SceneEncoderNodeConfig

    node, executor = ros(SceneEncoderNode)

    def current(name):
        c = node.config
        assert ticks_at(node._status_timer, c.status_rate_hz)
        assert node.monitor.stale_after_s == c.stale_after_s and node.fusion.max_age_s == c.cloud_max_age_s
        return to_params(c)[name]

    outcomes = walk(node, executor, param_specs(SceneEncoderNodeConfig(), RANGES, READ_ONLY), current)
    assert outcomes["max_points"] == "applied" and outcomes["checkpoint"].startswith("refused")


def test_sim(ros):
    from sim_bridge.node import SimNode
    from sim_bridge.sim_config import SimConfig
    from sim_bridge.sim_ranges import SIM_RANGES, SIM_READ_ONLY

    small = ["-p", "camera.width:=64", "-p", "camera.height:=48", "-p", "scenario:=empty"]
    node, executor = ros(SimNode, "-p", "cameras:=[camera, front]", *small)
    fields = param_specs(node.config.camera, SIM_RANGES)
    specs = param_specs(SimConfig(), SIM_RANGES, SIM_READ_ONLY)
    specs.pop("camera.width"), specs.pop("camera.height")  # large pictures would only slow the resets down
    specs |= {f"front.{f}": replace(s, name=f"front.{f}") for f, s in fields.items() if f not in ("width", "height")}
    reset = node._on_reset.__func__

    def current(name):  # applied at the next sim/reset (real_time_factor at once)
        from std_srvs.srv import Trigger

        response = reset(node, Trigger.Request(), Trigger.Response())
        assert response.success, response.message
        assert node.sim.config == node.config and node.sim.cameras == node.named_cameras
        assert node.runner.real_time_factor == node.config.real_time_factor
        if name.startswith("front."):
            return to_params(node.named_cameras["front"])[name.removeprefix("front.")]
        return to_params(node.sim.config)[name]

    outcomes = walk(node, executor, specs, current)
    assert outcomes["front.rate"] == "applied" and outcomes["seed"] == "applied"
    assert outcomes["cameras"].startswith("refused")

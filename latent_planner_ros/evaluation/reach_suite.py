"""Static reach through the node suite: the same goal from the same start, planned by each planner node
and executed by the sim.

The suite is ``sim``, ``scene_encoder`` (learned collision backend only), ``planner`` (AMP-LS, closed loop
disabled) and ``ompl_planner`` (its own execution off), each a process with its ``config/<node>.yaml``. For
every goal and planner the sim is set to the goal's scenario and seed and reset (the arm back at its
``initial_q``), runs `settle_s` of simulated time so the clouds (and embeddings) reach the planners, then
``<planner>/plan`` is called and the returned trajectory is streamed on ``joint_command``.
"""

from __future__ import annotations

import time

from latent_planner_ros.evaluation.conveyor_suite import (
    ConveyorSuite,
    SuiteFailed,
    SuitePlan,
    collision_weights,
    configured_planner,
)
from latent_planner_ros.evaluation.reach import reach_metrics
from latent_planner_ros.evaluation.reach_goals import ReachGoal
from latent_planner_ros.processes.node_suite import SuiteError

PLANNERS = ("planner", "ompl_planner")
"""The planner nodes compared, both behind nav_msgs/GetPlan."""
PLAN_TOLERANCE_M = 0.01
"""[m] the `tolerance` of every GetPlan request."""


def reach_plan(backend: str | None = None, real_time_factor: float = 1.0) -> SuitePlan:
    """The suite's processes; backend None = config/planner.yaml's (geometric if the learned weights are missing).

    Raises:
        SuiteError: "learned" asked for explicitly but its weights are not installed.
    """
    configured, checkpoint = configured_planner()
    chosen, notes = backend or configured, []
    if chosen == "learned" and not collision_weights(checkpoint).is_file():
        if backend == "learned":
            raise SuiteError(f"the learned collision backend needs {collision_weights(checkpoint)}")
        notes.append("the learned collision weights are not installed: the planner uses the geometric backend")
        chosen = "geometric"
    nodes = ("sim", "scene_encoder", *PLANNERS) if chosen == "learned" else ("sim", *PLANNERS)
    planner = ["enabled:=false"] + ([f"amp_ls.collision_backend:={chosen}"] if chosen != configured else [])
    return SuitePlan(
        nodes=nodes,
        params={"sim": [f"real_time_factor:={float(real_time_factor)}"], "planner": planner, "ompl_planner": []},
        ros_args={},
        backend=chosen,
        configured_backend=configured,
        seed=0,
        real_time_factor=float(real_time_factor),
        notes=tuple(notes),
    )


def wait_sim_time(suite: ConveyorSuite, seconds: float, stall_s: float = 20.0) -> None:
    """Block until `seconds` [s] of simulated time have passed; SuiteFailed if a node dies or the clock stalls."""
    start = suite.monitor.clock()
    last, last_change = start, time.monotonic()
    while True:
        suite.check()
        clock = suite.monitor.clock()
        if clock != last:
            last, last_change = clock, time.monotonic()
        elif time.monotonic() - last_change > stall_s:
            raise SuiteFailed("sim", f"simulated time stopped at {clock:.2f} s")
        if clock is not None and start is not None and clock - start >= seconds:
            return
        time.sleep(0.02)


def run_goal(suite: ConveyorSuite, probe, goal: ReachGoal, planner: str, settle_s: float = 2.0) -> dict:
    """Reset the sim into the goal's scene, plan with `planner`, execute; the reach_metrics row (with the goal)."""
    suite.monitor.set_sim_parameters(scenario=goal.scenario, seed=int(goal.seed))
    suite.monitor.reset_sim()
    wait_sim_time(suite, settle_s)
    call = probe.plan(planner, goal.position, goal.quaternion_xyzw, PLAN_TOLERANCE_M)
    log, finished = probe.execute(call.q_path, call.times) if call.planned else (None, False)
    suite.check()
    row = reach_metrics(call, log, goal.position, goal.quaternion_xyzw)
    return {"scenario": goal.scenario, "seed": goal.seed, "execution_finished": finished, **row}

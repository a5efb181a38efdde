"""The nodes' callbacks as fuzzing boundaries: each node built in-process, its subscriber, service and parameter
callbacks called directly with generated inputs (no executor, no other process; rclpy must be initialised).

A callback's check returns "accepted", "refused" or "failed" (a plan that ran and did not reach); it raises
InvariantError when a refusal leaves no reason (no warning logged, no reason on ~/plan_result or in the parameter
result), a command leaves the joint limits, or the node does not take up an input its adapter accepted. Any
exception escaping a callback escapes the check (in a node it would stop the executor). `handles_valid_input`
feeds valid inputs after the fuzzing and checks they are still handled.
"""

from __future__ import annotations

from collections import deque
from functools import partial

import mujoco
import numpy as np
from nav_msgs.srv import GetPlan
from rcl_interfaces.srv import SetParameters
from rclpy.publisher import Publisher
from std_srvs.srv import SetBool, Trigger
from visualization_msgs.msg import Marker, MarkerArray

from latent_planner_ros.bench import fuzz_strategies as fs
from latent_planner_ros.bench.fuzz_adapters import ACCEPTED, REFUSED, Boundary, expect, refusal
from latent_planner_ros.evaluation.fault_inputs import box_cloud, goal_pose
from latent_planner_ros.perception.cloud_fusion import CloudRefused
from latent_planner_ros.robot.limits import JOINT_NAMES, Q_MAX, Q_MIN, Q_READY
from msg_adapters import (
    apply_marker_array,
    cloud_to_embedding,
    cloud_to_xyz,
    joint_state_to_q,
    pose_stamped_to_target,
    q_to_joint_state,
    trajectory_to_execution,
)
from msg_adapters.pose import pose_stamped_in_base

FAILED = "failed"
WARNINGS = ("warning", "error", "fatal")
TOPIC = "camera/points"


class LogRecorder:
    """Stands in for a node's logger: keeps (level, text) of every call, throttled or not, and prints nothing."""

    def __init__(self):
        self.records: list[tuple[str, str]] = []

    def _log(self, level: str, message, **_) -> bool:
        self.records.append((level, str(message)))
        return True

    def __getattr__(self, level: str):
        if level in ("debug", "info", "warning", "warn", "error", "fatal"):
            return partial(self._log, "warning" if level == "warn" else level)
        raise AttributeError(level)

    def warnings(self) -> list[str]:
        return [text for level, text in self.records if level in WARNINGS]


class PublisherRecorder:
    """Stands in for a publisher: counts the messages and keeps the last few."""

    def __init__(self):
        self.count, self.msgs = 0, deque(maxlen=8)

    def publish(self, msg) -> None:
        self.count += 1
        self.msgs.append(msg)


class NodeFuzz:
    """One node in-process with a recording logger and recording publishers."""

    name = ""

    def __init__(self, node):
        self.node = node
        self.startup = {n: p.value for n, p in node._parameters.items() if n != "use_sim_time"}
        self.log = LogRecorder()
        node._logger = self.log
        self.pubs = {}
        for attr, value in list(vars(node).items()):
            if isinstance(value, Publisher):
                self.pubs[attr] = PublisherRecorder()
                setattr(node, attr, self.pubs[attr])

    def call(self, fn, *args):
        """(result of fn(*args), the warnings it logged)."""
        self.log.records.clear()
        return fn(*args), self.log.warnings()

    def expect_reason(self, logs: list[str], reason: str, what: str) -> str:
        expect(any(reason in text for text in logs), f"{what}: refused ({reason!r}) without saying so: {logs}")
        return REFUSED

    def expect_logged(self, logs: list[str], what: str) -> str:
        expect(any(text.strip() for text in logs), f"{what}: not taken up and nothing logged")
        return REFUSED

    def set_parameter(self, param) -> str:
        """One parameter through the node's set_parameters service callback, as `ros2 param set` reaches it."""
        request = SetParameters.Request(parameters=[param.to_parameter_msg()])
        result = self.node._parameter_service._set_parameters_callback(request, SetParameters.Response()).results[0]
        if result.successful:
            return ACCEPTED
        expect(bool(result.reason.strip()), f"parameter {param.name} = {param.value!r} refused without a reason")
        return REFUSED

    def parameter_boundary(self) -> Boundary:
        current = {n: _plain(v) for n, v in self.startup.items()}
        return Boundary(f"{self.name}.parameters", fs.parameters(current), self.set_parameter)

    def boundaries(self) -> tuple[Boundary, ...]:
        return ()

    def all_boundaries(self) -> dict[str, Boundary]:
        """{name: boundary} of the node's callbacks and its parameters."""
        return {b.name: b for b in (*self.boundaries(), self.parameter_boundary())}

    def handles_valid_input(self) -> None:
        raise NotImplementedError

    def restore_parameters(self) -> None:
        """Every parameter back to its start-up value; each must be accepted."""
        for name, value in self.startup.items():
            param = self.node.get_parameter(name)
            if _plain(param.value) != _plain(value) and not self.node.describe_parameter(name).read_only:
                outcome = self.set_parameter(type(param)(name, param.type_, value))
                expect(outcome == ACCEPTED, f"{name} could not be set back to {value!r}")

    def close(self) -> None:
        self.node.destroy_node()


def _plain(value):
    return list(value) if not isinstance(value, str | bytes) and hasattr(value, "__len__") else value


def _commands_within_limits(pub: PublisherRecorder, seen: int) -> int:
    for msg in list(pub.msgs)[-(pub.count - seen) :] if pub.count > seen else []:
        q = np.asarray(msg.position, dtype=float)
        expect(bool(np.all(np.isfinite(q))), f"joint_command not finite: {q}")
        expect(bool(np.all((q >= Q_MIN - 1e-6) & (q <= Q_MAX + 1e-6))), f"joint_command outside the limits: {q}")
    return pub.count


class PlannerFuzz(NodeFuzz):
    """The planner node (the shipped configuration: learned backend), enabled, its callbacks driven by hand."""

    name = "planner"

    def __init__(self, node, embedding=None):
        super().__init__(node)
        self._seen = 0
        self.embedding = embedding  # a valid scene_embedding message (fuzzed variants, plans, handles_valid_input)
        self._embedding_variants = fs.embedding_variants(embedding) if embedding is not None else fs.embedding_clouds()
        node._on_enable(SetBool.Request(data=True), SetBool.Response())

    def _fresh_state(self) -> None:
        self.node._on_joint_states(q_to_joint_state(Q_READY, names=self.node.joint_names))

    def _tick(self) -> list[str]:
        _, logs = self.call(self.node._on_tick)
        self._seen = _commands_within_limits(self.pubs["pub_command"], self._seen)
        return logs

    def joint_states(self, msg) -> str:
        out, reason = refusal(joint_state_to_q, msg, self.node.joint_names)
        _, logs = self.call(self.node._on_joint_states, msg)
        if reason:
            return self.expect_reason(logs, reason, "joint_states")
        q = self.node.modes.active.fresh_joint_state(self.node._now())
        if q is not None and np.array_equal(q, out[0]):
            return ACCEPTED
        return self.expect_reason(logs, "joint_states refused", "joint_states")

    def goal(self, msg) -> str:
        self._fresh_state()
        target, reason = refusal(pose_stamped_in_base, msg, self.node.frames)
        _, logs = self.call(self.node._on_goal, msg)
        logs += self._tick()
        if reason:
            return self.expect_reason(logs, reason, "goal_pose")
        goal = self.node.modes.goal
        if goal is not None and np.array_equal(goal.position, target.position):
            return ACCEPTED
        return self.expect_logged(logs, "goal_pose")

    def cloud(self, msg) -> str:
        try:
            self.node.fusion.check(TOPIC, msg.header.frame_id)
            _, reason = refusal(cloud_to_xyz, msg)
        except CloudRefused as err:
            reason = str(err)
        _, logs = self.call(self.node._on_cloud, TOPIC, msg)
        logs += self._tick()
        return self.expect_reason(logs, reason, TOPIC) if reason else ACCEPTED

    def embedding_msg(self, msg) -> str:
        _, reason = refusal(cloud_to_embedding, msg)
        before = self.node.modes.amp_ls.scene
        _, logs = self.call(self.node._on_embedding, msg)
        if reason:
            return self.expect_reason(logs, reason, "scene_embedding")
        if self.node.modes.amp_ls.scene is before:
            return self.expect_reason(logs, "scene_embedding refused", "scene_embedding")
        self._tick()
        return ACCEPTED

    def obstacles(self, msg) -> str:
        cfg = self.node.config
        update, reason = refusal(
            apply_marker_array, msg, self.node._cylinders, cfg.tuning.obstacle_tilt_tol_deg, cfg.tuning.obstacle_z_tol_m
        )
        _, logs = self.call(self.node._on_obstacles, msg)
        logs += self._tick()
        if reason:
            outcome = self.expect_reason(logs, reason, "obstacles")
        elif set(self.node._cylinders) == set(update.cylinders):
            outcome = ACCEPTED
        else:
            outcome = self.expect_reason(logs, "obstacles refused", "obstacles")
        self.node._on_obstacles(MarkerArray(markers=[Marker(action=Marker.DELETEALL)]))  # back to AMP-LS
        return outcome

    def _scene(self) -> None:
        """The valid embedding and the box cloud, so fuzzed plan requests reach the planner."""
        if self.embedding is not None:
            self.node._on_embedding(self.embedding)
        self.node._on_cloud(TOPIC, box_cloud())

    def plan(self, request, grasp: bool = False) -> str:
        self._fresh_state()
        if self.node.modes.amp_ls.scene is None or self.node.modes.amp_ls.cloud is None:
            self._scene()
        pub = self.pubs["pub_plan_result"]
        before = pub.count
        response = self.node._on_plan(request, GetPlan.Response(), grasp)
        expect(isinstance(response, GetPlan.Response) and pub.count == before + 1, "no response or no plan_result")
        return plan_outcome(pub.msgs[-1])

    def boundaries(self) -> tuple[Boundary, ...]:
        return (
            Boundary("planner.joint_states", fs.joint_states(), self.joint_states),
            Boundary("planner.goal_pose", fs.pose_stampeds(), self.goal),
            Boundary("planner.camera_points", fs.point_clouds(), self.cloud),
            Boundary("planner.scene_embedding", fs.embedding_clouds() | self._embedding_variants, self.embedding_msg),
            Boundary("planner.obstacles", fs.marker_arrays(), self.obstacles),
            Boundary("planner.plan", fs.plan_requests(), self.plan),
            Boundary("planner.plan_grasp", fs.plan_requests(), partial(self.plan, grasp=True)),
        )

    def handles_valid_input(self) -> None:
        self.node._on_enable(SetBool.Request(data=True), SetBool.Response())  # `enabled` may have been set back
        self.node._on_obstacles(MarkerArray(markers=[Marker(action=Marker.DELETEALL)]))
        self._fresh_state()
        expect(self.node.modes.active.fresh_joint_state(self.node._now()) is not None, "a valid joint state refused")
        self.node._on_cloud(TOPIC, box_cloud())
        if self.embedding is not None:
            expect(self.embedding_msg(self.embedding) == ACCEPTED, "a valid scene embedding refused")
        self._tick()
        expect(self.node._cloud_points[1] > 0, "a valid cloud not taken up")
        request = GetPlan.Request(goal=goal_pose("A"))
        expect(self.plan(request) != REFUSED, "a valid plan request refused")
        _, logs = self.call(self.node._on_goal, goal_pose("A"))
        expect(self.node.modes.goal is not None, f"a valid goal refused: {logs}")
        before = self.pubs["pub_command"].count
        for _ in range(3):
            self._fresh_state()
            self._tick()
        expect(self.pubs["pub_command"].count > before, "no command after a valid goal")


def plan_outcome(status) -> str:
    """accepted / failed / refused of a ~/plan_result DiagnosticStatus; InvariantError if a failure has no reason."""
    values = {kv.key: kv.value for kv in status.values}
    if values.get("success") == "true":
        return ACCEPTED
    expect(bool(values.get("reason", "").strip()) and bool(status.message.strip()), f"no reason: {status}")
    return REFUSED if status.message.startswith("refused") else FAILED


class OmplFuzz(NodeFuzz):
    name = "ompl_planner"

    def _fresh_state(self) -> None:
        self.node._on_joint_states(q_to_joint_state(Q_READY, names=self.node.joint_names))

    def joint_states(self, msg) -> str:
        out, reason = refusal(joint_state_to_q, msg, self.node.joint_names)
        _, logs = self.call(self.node._on_joint_states, msg)
        if reason:
            return self.expect_reason(logs, reason, "joint_states")
        expect(np.array_equal(self.node._q, out[0]), "an accepted joint state not taken up")
        return ACCEPTED

    def cloud(self, msg) -> str:
        try:
            self.node.fusion.check(TOPIC, msg.header.frame_id)
            _, reason = refusal(cloud_to_xyz, msg)
        except CloudRefused as err:
            reason = str(err)
        _, logs = self.call(self.node._on_cloud, TOPIC, msg)
        return self.expect_reason(logs, reason, TOPIC) if reason else ACCEPTED

    def plan(self, request, grasp: bool = False) -> str:
        self._fresh_state()
        self.node._on_cloud(TOPIC, box_cloud())  # a scene, so fuzzed requests reach the planner
        pub = self.pubs["pub_plan_result"]
        before = pub.count
        response = self.node._on_plan(request, GetPlan.Response(), grasp)
        expect(isinstance(response, GetPlan.Response) and pub.count == before + 1, "no response or no plan_result")
        self.node._publish_status()
        return plan_outcome(pub.msgs[-1])

    def boundaries(self) -> tuple[Boundary, ...]:
        return (
            Boundary("ompl_planner.joint_states", fs.joint_states(), self.joint_states),
            Boundary("ompl_planner.camera_points", fs.point_clouds(), self.cloud),
            Boundary("ompl_planner.plan", fs.plan_requests(), self.plan),
            Boundary("ompl_planner.plan_grasp", fs.plan_requests(), partial(self.plan, grasp=True)),
        )

    def handles_valid_input(self) -> None:
        self._fresh_state()
        self.node._on_cloud(TOPIC, box_cloud())
        expect(self.plan(GetPlan.Request(goal=goal_pose("A"))) == ACCEPTED, "a valid plan request not planned")


class SceneEncoderFuzz(NodeFuzz):
    name = "scene_encoder"

    def cloud(self, msg) -> str:
        try:
            self.node.fusion.check(TOPIC, msg.header.frame_id)
            _, reason = refusal(cloud_to_xyz, msg)
        except CloudRefused as err:
            reason = str(err)
        _, logs = self.call(self.node._on_cloud, TOPIC, msg)
        self.node._publish_status()
        if reason:
            self.expect_reason(logs, reason, TOPIC)
            expect(reason in self.node.monitor.last_error, f"status does not say {reason!r}")
            return REFUSED
        return ACCEPTED

    def camera_pose(self, msg) -> str:
        _, reason = refusal(pose_stamped_to_target, msg, None)  # the node reads the pose, then checks its frame
        try:
            self.node.fusion.check(TOPIC, msg.header.frame_id)
        except CloudRefused as err:
            reason = reason or str(err).split("refused: ", 1)[-1]  # the node names the pose topic
        _, logs = self.call(self.node._on_camera_pose, TOPIC, msg)
        return self.expect_reason(logs, reason, "camera/pose") if reason else ACCEPTED

    def boundaries(self) -> tuple[Boundary, ...]:
        return (
            Boundary("scene_encoder.camera_points", fs.point_clouds(), self.cloud),
            Boundary("scene_encoder.camera_pose", fs.pose_stampeds(), self.camera_pose),
        )

    def handles_valid_input(self) -> None:
        pub = self.pubs["pub_embedding"]
        before = pub.count
        self.node._on_cloud(TOPIC, box_cloud())
        expect(pub.count == before + 1, f"no embedding of a valid cloud: {self.node.monitor.last_error}")
        expect(len(cloud_to_embedding(pub.msgs[-1])[0]) > 0, "an empty embedding of the box")


class SimFuzz(NodeFuzz):
    name = "sim"

    def command(self, msg) -> str:
        _, reason = refusal(joint_state_to_q, msg)
        unknown = sorted(set(msg.name) - set(JOINT_NAMES))
        _, logs = self.call(self.node._on_command, msg)
        self._step()
        if unknown:
            return self.expect_reason(logs, "unknown joints", "joint_command")
        if reason:
            return self.expect_reason(logs, reason, "joint_command")
        return ACCEPTED

    def trajectory(self, msg) -> str:
        _, reason = refusal(trajectory_to_execution, msg)
        _, logs = self.call(self.node._on_trajectory, msg)
        self._step()
        if reason:
            return self.expect_reason(logs, reason, "joint_trajectory")
        if self.node.sim.trajectory_running() or not logs:
            return ACCEPTED
        return self.expect_reason(logs, "joint_trajectory refused", "joint_trajectory")

    def _step(self) -> None:
        """Five physics steps on the command just given: the arm's state stays finite and MuJoCo never sees a
        non-finite or huge actuator value (it would reset the simulation: the arm jumps to its start pose)."""
        data = self.node.sim.data
        bad_before = int(data.warning[mujoco.mjtWarning.mjWARN_BADCTRL].number)
        self.node.sim.step(5)
        expect(bool(np.all(np.isfinite(self.node.sim.get_state().q))), "the simulated arm's state is not finite")
        bad = int(data.warning[mujoco.mjtWarning.mjWARN_BADCTRL].number) - bad_before
        expect(bad == 0, "a command put a non-finite or huge value in MuJoCo's actuator controls (simulation reset)")

    def boundaries(self) -> tuple[Boundary, ...]:
        return (
            Boundary("sim.joint_command", fs.joint_states(), self.command),
            Boundary("sim.joint_trajectory", fs.joint_trajectories(), self.trajectory),
            sim_reset_boundary(self),
        )

    def reset(self) -> str:
        response = self.node._on_reset(Trigger.Request(), Trigger.Response())
        expect(bool(response.message.strip()), "sim/reset answered without a message")
        return ACCEPTED if response.success else REFUSED

    def handles_valid_input(self) -> None:
        expect(self.reset() == ACCEPTED, "sim/reset refused with the start-up parameters")
        target = Q_READY + 0.1
        self.node._on_command(q_to_joint_state(target))
        self.node.sim.step(500)
        q = self.node.sim.get_state().q
        expect(bool(np.max(np.abs(q - target)) < 0.05), f"the arm did not follow a valid command: {q}")


def sim_reset_boundary(fuzz: SimFuzz) -> Boundary:
    """sim/reset after a parameter change (Trigger has no fields: the input is the parameter)."""

    def check(param) -> str:
        fuzz.set_parameter(param)
        return fuzz.reset()

    current = {n: _plain(v) for n, v in fuzz.startup.items()}
    return Boundary("sim.reset", fs.parameters(current), check)


def build(name: str) -> NodeFuzz:
    """The fuzz harness of node `name` (planner, ompl_planner, scene_encoder, sim), built in-process; plans are
    cut at 0.5 s (amp_ls.timeout_s, ompl.timeout_s) so a fuzzed goal costs little."""
    from rclpy.parameter import Parameter

    if name == "planner":
        from latent_planner_ros.nodes.planner import PlannerNode

        fuzz = PlannerFuzz(PlannerNode(), embedding=valid_embedding())
        fuzz.set_parameter(Parameter("amp_ls.timeout_s", value=0.5))
    elif name == "ompl_planner":
        from latent_planner_ros.nodes.ompl_planner import OmplPlannerNode

        fuzz = OmplFuzz(OmplPlannerNode())
        fuzz.set_parameter(Parameter("ompl.timeout_s", value=0.5))
    elif name == "scene_encoder":
        from latent_planner_ros.nodes.scene_encoder import SceneEncoderNode

        fuzz = SceneEncoderFuzz(SceneEncoderNode())
    elif name == "sim":
        from sim_bridge.node import SimNode

        fuzz = SimFuzz(SimNode())
    else:
        raise ValueError(f"no fuzz harness for node {name!r}")
    fuzz.startup = {n: p.value for n, p in fuzz.node._parameters.items() if n != "use_sim_time"}
    return fuzz


def valid_embedding():
    """The shipped scene encoder's embedding (PointCloud2) of the fault suite's box cloud."""
    from latent_planner_ros.nodes.scene_encoder import SceneEncoderNode

    fuzz = SceneEncoderFuzz(SceneEncoderNode())
    try:
        fuzz.node._on_cloud(TOPIC, box_cloud())
        return fuzz.pubs["pub_embedding"].msgs[-1]
    finally:
        fuzz.close()


NODE_BOUNDARIES = {
    "planner": ("joint_states", "goal_pose", "camera_points", "scene_embedding", "obstacles", "plan", "plan_grasp"),
    "ompl_planner": ("joint_states", "camera_points", "plan", "plan_grasp"),
    "scene_encoder": ("camera_points", "camera_pose"),
    "sim": ("joint_command", "joint_trajectory", "reset"),
}
"""{node: its callback boundaries}; each node also has `parameters`."""

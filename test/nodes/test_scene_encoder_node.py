"""The scene_encoder node as a process: embeddings of valid clouds, refusals of malformed ones, parameters,
staleness, a clean stop, and a clear exit on a missing or corrupt checkpoint."""

from __future__ import annotations

import json
import os
import random
import signal
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import torch

from latent_planner_ros.models.collision_io import load_scene_encoder, save_collision_net
from latent_planner_ros.models.collision_net import CollisionNet
from latent_planner_ros.models.collision_net_config import CollisionNetConfig
from latent_planner_ros.models.scene_encoder import SceneEmbedding, SceneEncoderConfig

REPO = Path(__file__).resolve().parents[2]

PROBE = r"""
import json, sys, time
import numpy as np
import rclpy
from builtin_interfaces.msg import Time
from diagnostic_msgs.msg import DiagnosticArray
from rcl_interfaces.msg import Parameter, ParameterType, ParameterValue
from rcl_interfaces.srv import SetParameters
from geometry_msgs.msg import PoseStamped
from sensor_msgs.msg import PointCloud2
from msg_adapters import cloud_to_embedding, xyz_to_cloud

out_dir = sys.argv[1]
rng = np.random.default_rng(7)
rclpy.init()
node = rclpy.create_node("scene_encoder_probe")
embeddings, statuses = {}, []
node.create_subscription(
    PointCloud2, "scene_embedding", lambda m: embeddings.setdefault((m.header.stamp.sec, m.header.frame_id), m), 10
)
node.create_subscription(DiagnosticArray, "scene_encoder/status", lambda m: statuses.append(m.status[0]), 50)
pub = node.create_publisher(PointCloud2, "camera/points", 10)
pose_pub = node.create_publisher(PoseStamped, "camera/pose", 10)

def spin_until(cond, timeout):
    end = time.monotonic() + timeout
    while not cond() and time.monotonic() < end:
        rclpy.spin_once(node, timeout_sec=0.05)
    return cond()

def status_dict(s):
    return {"level": s.level[0], "message": s.message, "values": {kv.key: kv.value for kv in s.values}}

def send(name, msg, sec, expect, embedding):
    # publish (again every 0.5 s: discovery may still be going on) until the status shows `expect`
    msg.header.stamp = Time(sec=sec, nanosec=7)
    def done():
        ok = bool(statuses) and expect in statuses[-1].message
        return ok and (not embedding or (sec, "panda_link0") in embeddings)
    for _ in range(40):
        pub.publish(msg)
        if spin_until(done, 0.5):
            break
    assert done(), f"{name}: no status {expect!r} (last {statuses[-1].message if statuses else None!r})"
    results[name] = status_dict(statuses[-1])

def set_param(name, kind, value):
    client = node.create_client(SetParameters, "scene_encoder/set_parameters")
    assert client.wait_for_service(timeout_sec=10.0)
    field = {ParameterType.PARAMETER_INTEGER: "integer_value", ParameterType.PARAMETER_STRING: "string_value",
             ParameterType.PARAMETER_BOOL: "bool_value", ParameterType.PARAMETER_DOUBLE: "double_value"}[kind]
    p = Parameter(name=name, value=ParameterValue(type=kind, **{field: value}))
    future = client.call_async(SetParameters.Request(parameters=[p]))
    rclpy.spin_until_future_complete(node, future, timeout_sec=10.0)
    r = future.result().results[0]
    return [r.successful, r.reason]

results = {}
assert spin_until(lambda: len(statuses) > 0, 60.0), "no status from scene_encoder"
results["first_status"] = status_dict(statuses[0])

inside = rng.uniform([0.2, -0.4, 0.0], [0.8, 0.4, 0.4], size=(2000, 3))
outside = rng.uniform([1.2, -2.0, -1.0], [2.0, 2.0, 2.0], size=(50, 3))
valid = np.r_[inside, outside, np.full((5, 3), np.nan)].astype(np.float32)
np.save(f"{out_dir}/valid.npy", valid)
send("valid", xyz_to_cloud(valid), 101, "encoded 2000 points", True)

missing_z = xyz_to_cloud(valid)
missing_z.fields = missing_z.fields[:2]
send("missing_field", missing_z, 102, "lacks fields", False)
truncated = xyz_to_cloud(valid)
truncated.data = truncated.data[:-5]
send("truncated", truncated, 103, "truncated", False)
send("wrong_frame", xyz_to_cloud(valid, frame_id="camera"), 104, "frame 'camera'", False)
send("nan_points", xyz_to_cloud(np.full((30, 3), np.nan)), 105, "empty cloud", True)
send("valid_again", xyz_to_cloud(inside[:500]), 106, "encoded 500 points", True)
send("zero_points", xyz_to_cloud(np.zeros((0, 3))), 107, "empty cloud", True)

results["bad_max_points"] = set_param("max_points", ParameterType.PARAMETER_INTEGER, -1)
results["bad_checkpoint"] = set_param("checkpoint", ParameterType.PARAMETER_STRING, f"{out_dir}/nope")
results["use_sim_time"] = set_param("use_sim_time", ParameterType.PARAMETER_BOOL, False)
results["max_points"] = set_param("max_points", ParameterType.PARAMETER_INTEGER, 1000)
big = rng.uniform([0.0, -0.6, 0.0], [1.0, 0.6, 0.5], size=(20000, 3)).astype(np.float32)
send("big", xyz_to_cloud(big), 108, "downsampled from 20000", True)

def with_pose(name, pose_xyz, pose_sec, cloud, sec, expect):
    # publish the camera pose and then the cloud until the status shows `expect` for that cloud
    pose = PoseStamped()
    pose.header.frame_id, pose.header.stamp = "world", Time(sec=pose_sec)
    pose.pose.position.x, pose.pose.position.y, pose.pose.position.z = pose_xyz
    pose.pose.orientation.w = 1.0
    msg = xyz_to_cloud(cloud)
    msg.header.stamp = Time(sec=sec)
    def done():
        if not statuses or f"encoded {len(cloud)} points" not in statuses[-1].message:
            return False
        return expect in status_dict(statuses[-1])["values"]["camera_origin"] and (sec, "panda_link0") in embeddings
    for _ in range(40):
        pose_pub.publish(pose)
        spin_until(lambda: False, 0.1)
        pub.publish(msg)
        if spin_until(done, 0.5):
            break
    assert done(), f"{name}: last status {status_dict(statuses[-1]) if statuses else None!r}"
    results[name] = status_dict(statuses[-1])

seen = inside[:300].astype(np.float32)
np.save(f"{out_dir}/seen.npy", seen)
with_pose("origin_known", (1.6, 0.7, 0.9), 201, seen, 201, "known")
with_pose("origin_refused", (float("nan"), 0.0, 1.0), 201, inside[:301], 203, "unknown: newest camera/pose is 2.00 s")

for sec in (101, 105, 106, 107, 108, 201):
    c, f = cloud_to_embedding(embeddings[(sec, "panda_link0")])
    np.savez(f"{out_dir}/embedding_{sec}.npz", centres=c, features=f)
results["embedding_stamps"] = sorted(s for s, _ in embeddings)
results["embedding_nanosec"] = embeddings[(101, "panda_link0")].header.stamp.nanosec
assert spin_until(lambda: "stale" in statuses[-1].message, 10.0), statuses[-1].message
results["stale"] = status_dict(statuses[-1])
print(json.dumps(results))
"""


def child_env(domain_id: int) -> dict[str, str]:
    env = dict(os.environ, ROS_DOMAIN_ID=str(domain_id), PYTHONUNBUFFERED="1")
    env["PYTHONPATH"] = os.pathsep.join([str(REPO), *filter(None, [env.get("PYTHONPATH")])])
    return env


def stop(proc: subprocess.Popen, sig: int = signal.SIGINT) -> str:
    """Signal (then kill) a child; returns its stderr."""
    if proc.poll() is None:
        proc.send_signal(sig)
    try:
        _, err = proc.communicate(timeout=15)
    except subprocess.TimeoutExpired:
        proc.kill()
        _, err = proc.communicate(timeout=5)
    return err or ""


def node_cmd(*ros_args: str) -> list[str]:
    return [sys.executable, "-m", "latent_planner_ros", "run", "scene_encoder", "--ros-args", *ros_args]


@pytest.fixture
def checkpoint(tmp_path) -> Path:
    """An untrained collision net with the default (shipped) encoder grid and visibility channels, small elsewhere."""
    net = CollisionNet(CollisionNetConfig(encoder=SceneEncoderConfig(visibility=True), hidden=(16,)))
    save_collision_net(tmp_path / "collision", net, {"note": "untrained, for tests"})
    return tmp_path / "collision"


@pytest.mark.ros
@pytest.mark.slow
@pytest.mark.timeout(120)
def test_scene_encoder_node_end_to_end(tmp_path, checkpoint):
    env = child_env(random.SystemRandom().randint(1, 100))
    args = ["-p", f"checkpoint:={checkpoint}", "-p", "status_rate_hz:=20.0", "-p", "stale_after_s:=1.5"]
    node = subprocess.Popen(
        node_cmd(*args), cwd=REPO, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
    )
    try:
        probe = subprocess.run(
            [sys.executable, "-c", PROBE, str(tmp_path)],
            cwd=REPO,
            env=env,
            capture_output=True,
            text=True,
            timeout=100,
        )
        assert probe.returncode == 0, f"probe failed:\n{probe.stderr[-3000:]}\nnode:\n{stop(node)[-3000:]}"
        result = json.loads(probe.stdout.strip().splitlines()[-1])
        assert node.poll() is None, "the node stopped"
    finally:
        log = stop(node, signal.SIGTERM)
    assert node.returncode == 0, log[-3000:]
    assert "Traceback" not in log, log[-3000:]

    # the first valid cloud: the published embedding is what the encoder makes of the same cloud
    encoder = load_scene_encoder(checkpoint)
    valid = np.load(tmp_path / "valid.npy")
    with torch.no_grad():
        expected = encoder.encode(valid[np.all(np.isfinite(valid), axis=1)])
    got = np.load(tmp_path / "embedding_101.npz")
    rebuilt = SceneEmbedding.from_points(got["centres"], got["features"], encoder.config)
    torch.testing.assert_close(rebuilt.features, expected.features, atol=1e-5, rtol=1e-5)
    assert got["features"].shape == (int(np.prod(encoder.config.grid_shape)), encoder.config.channels)
    assert result["embedding_nanosec"] == 7, "the header stamp is the input cloud's"

    ok = result["valid"]
    assert ok["level"] == 0 and ok["values"]["points_in"] == "2055" and ok["values"]["points_used"] == "2000"
    assert float(ok["values"]["encode_ms"]) > 0.0
    for name, reason in (("missing_field", "lacks fields"), ("truncated", "truncated"), ("wrong_frame", "frame")):
        status = result[name]
        assert status["level"] == 2 and reason in status["values"]["last_error"], status
    for name in ("nan_points", "zero_points"):
        assert result[name]["level"] == 1 and result[name]["values"]["points_used"] == "0", result[name]
    assert result["valid_again"]["level"] == 0
    # nothing was published for the refused clouds; empty clouds are encoded as an empty scene
    assert result["embedding_stamps"] == [101, 105, 106, 107, 108, 201, 203]
    with torch.no_grad():
        empty = encoder.encode(np.zeros((0, 3), np.float32))
    got = np.load(tmp_path / "embedding_107.npz")
    rebuilt = SceneEmbedding.from_points(got["centres"], got["features"], encoder.config)
    torch.testing.assert_close(rebuilt.features, empty.features, atol=1e-5, rtol=1e-5)
    assert "refused" in log and "lacks fields" in log, "malformed clouds are logged"

    assert not result["bad_max_points"][0] and "max_points" in result["bad_max_points"][1]
    assert not result["bad_checkpoint"][0] and "nope.safetensors" in result["bad_checkpoint"][1]
    assert result["use_sim_time"][0], "ROS's own parameters are not ours to refuse"
    assert result["max_points"][0]
    big = result["big"]
    assert big["level"] == 0 and int(big["values"]["points_used"]) <= 1000 and big["values"]["points_in"] == "20000"
    # the camera origin: encoded with the pose of the same stamp; a refused pose keeps the previous one,
    # which is then too far in time from the next cloud
    assert result["valid"]["values"]["camera_origin"].startswith("unknown: no camera/pose")
    seen = np.load(tmp_path / "seen.npy")
    with torch.no_grad():
        expected = encoder.encode(seen, np.array([1.6, 0.7, 0.9]))
        blind = encoder.encode(seen)
    got = np.load(tmp_path / "embedding_201.npz")
    rebuilt = SceneEmbedding.from_points(got["centres"], got["features"], encoder.config)
    torch.testing.assert_close(rebuilt.features, expected.features, atol=1e-5, rtol=1e-5)
    assert not torch.allclose(rebuilt.features, blind.features, atol=1e-4)
    assert result["origin_known"]["values"]["camera_origin"] == "known"
    assert "camera/pose refused" in result["origin_refused"]["values"]["last_error"]
    assert result["origin_refused"]["level"] == 0, "a refused pose does not stop the encoding"
    assert result["stale"]["level"] >= 1 and result["stale"]["values"]["state"] == "stale"


@pytest.mark.ros
@pytest.mark.slow
@pytest.mark.timeout(90)
def test_scene_encoder_refuses_to_start_without_a_good_checkpoint(tmp_path, checkpoint):
    env = child_env(random.SystemRandom().randint(1, 100))
    corrupt = tmp_path / "corrupt"
    corrupt.with_suffix(".json").write_text(checkpoint.with_suffix(".json").read_text())
    corrupt.with_suffix(".safetensors").write_bytes(b"\x00garbage")
    cases = {
        "missing": (["-p", f"checkpoint:={tmp_path / 'nope'}"], "nope.safetensors"),
        "corrupt": (["-p", f"checkpoint:={corrupt}"], "corrupt.safetensors"),
        "bad_param": (["-p", f"checkpoint:={checkpoint}", "-p", "max_points:=0"], "max_points"),
    }
    procs = {
        name: subprocess.Popen(
            node_cmd(*args), cwd=REPO, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
        )
        for name, (args, _) in cases.items()
    }
    for name, proc in procs.items():
        try:
            _, err = proc.communicate(timeout=60)
        finally:
            if proc.poll() is None:
                proc.kill()
                proc.communicate()
        assert proc.returncode not in (0, None), f"{name}: exit code {proc.returncode}\n{err}"
        assert cases[name][1] in err and "cannot start" in err, f"{name}:\n{err}"
        assert "Traceback" not in err, f"{name}:\n{err}"


FUSE_PROBE = r"""
import json, sys, time
import numpy as np
import rclpy
from builtin_interfaces.msg import Time
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import PoseStamped
from sensor_msgs.msg import PointCloud2
from msg_adapters import cloud_to_embedding, xyz_to_cloud

out_dir = sys.argv[1]
rclpy.init()
node = rclpy.create_node("scene_encoder_fuse_probe")
embeddings, statuses = {}, []
node.create_subscription(
    PointCloud2, "scene_embedding", lambda m: embeddings.__setitem__(m.header.stamp.sec, m), 10
)  # the newest per stamp: the first cloud of a round may be encoded alone before the other camera is known
node.create_subscription(DiagnosticArray, "scene_encoder/status", lambda m: statuses.append(m.status[0]), 50)
pubs = {t: node.create_publisher(PointCloud2, f"{t}/points", 10) for t in ("camera", "left", "right")}
poses = {t: node.create_publisher(PoseStamped, f"{t}/pose", 10) for t in ("camera", "left")}
eyes = {"camera": (1.6, 0.7, 0.9), "left": (0.4, -1.1, 1.0)}
rng = np.random.default_rng(3)
clouds = {"camera": rng.uniform([0.2, -0.4, 0.0], [0.8, 0.0, 0.4], size=(400, 3)).astype(np.float32),
          "left": rng.uniform([0.2, 0.0, 0.0], [0.8, 0.4, 0.4], size=(300, 3)).astype(np.float32)}
np.savez(f"{out_dir}/fuse_inputs.npz", **clouds)

def spin_until(cond, timeout):
    end = time.monotonic() + timeout
    while not cond() and time.monotonic() < end:
        rclpy.spin_once(node, timeout_sec=0.05)
    return cond()

def values(s):
    return {"level": s.level[0], "message": s.message, **{kv.key: kv.value for kv in s.values}}

def pose(t, sec):
    p = PoseStamped()
    p.header.frame_id, p.header.stamp = "world", Time(sec=sec)
    p.pose.position.x, p.pose.position.y, p.pose.position.z = eyes[t]
    p.pose.orientation.w = 1.0
    return p

def cloud(t, points, sec, frame="world"):
    m = xyz_to_cloud(points, frame_id=frame)
    m.header.stamp = Time(sec=sec)
    return m

def until(name, publish, cond, timeout=20.0):
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        publish()
        if spin_until(cond, 0.5):
            results[name] = values(statuses[-1])
            return
    raise AssertionError(f"{name}: last status {values(statuses[-1]) if statuses else None}")

results = {}
assert spin_until(lambda: len(statuses) > 0, 60.0), "no status from scene_encoder"
results["waiting"] = values(statuses[0])

def both(sec):
    def publish():
        for t in ("camera", "left"):
            poses[t].publish(pose(t, sec))
        spin_until(lambda: False, 0.1)
        for t in ("camera", "left"):
            pubs[t].publish(cloud(t, clouds[t], sec))
    return publish
until("fused", both(10), lambda: 10 in embeddings and "camera/points (400), left/points (300)" in
      values(statuses[-1])["cloud_sources"])
spin_until(lambda: False, 0.5)
# a camera that is not configured: right/points is not subscribed; a configured one in another frame is refused
until("wrong_frame", lambda: pubs["left"].publish(cloud("left", clouds["left"], 11, "left_optical_frame")),
      lambda: "left_optical_frame" in values(statuses[-1])["last_error"])
# left goes silent: once its cloud is stale the camera alone is encoded, and the status says so
def camera_only(sec):
    return lambda: pubs["camera"].publish(cloud("camera", clouds["camera"][:200], sec))
until("stale", camera_only(12), lambda: 12 in embeddings and "left/points" in values(statuses[-1])["clouds_stale"])
pubs["right"].publish(cloud("right", clouds["left"], 13))
until("still_working", both(14), lambda: 14 in embeddings and values(statuses[-1])["level"] == 0
      and values(statuses[-1])["clouds_stale"] == "")
c, f = cloud_to_embedding(embeddings[10])
np.savez(f"{out_dir}/fused_embedding.npz", centres=c, features=f)
results["stamps"] = sorted(embeddings)
print(json.dumps(results))
"""


@pytest.mark.ros
@pytest.mark.slow
@pytest.mark.timeout(120)
def test_scene_encoder_fuses_two_cameras_and_refuses_a_cloud_in_another_frame(tmp_path, checkpoint):
    env = child_env(random.SystemRandom().randint(1, 100))
    args = ["-p", f"checkpoint:={checkpoint}", "-p", "status_rate_hz:=20.0", "-p", "cloud_max_age_s:=1.0"]
    args += ["-p", "cloud_topics:=[camera/points, left/points]"]
    node = subprocess.Popen(
        node_cmd(*args), cwd=REPO, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
    )
    try:
        probe = subprocess.run(
            [sys.executable, "-c", FUSE_PROBE, str(tmp_path)],
            cwd=REPO,
            env=env,
            capture_output=True,
            text=True,
            timeout=100,
        )
        assert probe.returncode == 0, f"probe failed:\n{probe.stderr[-3000:]}\nnode:\n{stop(node)[-3000:]}"
        result = json.loads(probe.stdout.strip().splitlines()[-1])
        assert node.poll() is None, "the node stopped"
    finally:
        log = stop(node, signal.SIGTERM)
    assert node.returncode == 0 and "Traceback" not in log, log[-3000:]
    assert "camera/points, left/points" in result["waiting"]["message"]

    # the fused embedding is the encoder's of both clouds, each point with its own camera's origin
    encoder = load_scene_encoder(checkpoint)
    inputs = np.load(tmp_path / "fuse_inputs.npz")
    points = np.concatenate([inputs["camera"], inputs["left"]])
    origins = np.r_[np.tile([1.6, 0.7, 0.9], (400, 1)), np.tile([0.4, -1.1, 1.0], (300, 1))]
    with torch.no_grad():
        expected = encoder.encode(points, origins)
        first_only = encoder.encode(inputs["camera"], np.array([1.6, 0.7, 0.9]))
    got = np.load(tmp_path / "fused_embedding.npz")
    rebuilt = SceneEmbedding.from_points(got["centres"], got["features"], encoder.config)
    torch.testing.assert_close(rebuilt.features, expected.features, atol=1e-5, rtol=1e-5)
    assert not torch.allclose(rebuilt.features, first_only.features, atol=1e-4)
    fused = result["fused"]
    assert fused["camera_origin"] == "known" and fused["points_used"] == "700" and fused["points_in"] == "700"

    wrong = result["wrong_frame"]
    assert wrong["level"] == 2
    assert "left/points refused: frame 'left_optical_frame' has no transform to 'panda_link0'" in wrong["last_error"]
    assert "left_optical_frame" in log, "the refusal is logged"
    stale = result["stale"]
    assert "left/points (2.00 s behind)" in stale["clouds_stale"] and "stale" in stale["message"]
    assert stale["cloud_sources"] == "camera/points (200)"
    assert result["stamps"] == [10, 12, 14], "nothing published for the refused cloud or the unconfigured camera"

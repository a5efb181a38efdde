"""Several depth cameras: the rig from parameters and scenario files, each camera's cloud, and their fusion."""

from __future__ import annotations

import numpy as np
import pytest

from latent_planner_ros.params.config import ConfigError, from_params
from latent_planner_ros.perception.cloud_fusion import CloudFusion
from sim_bridge.camera_config import CameraConfig
from sim_bridge.camera_rig import camera_from_params, camera_params, camera_rig
from sim_bridge.runner import Runner
from sim_bridge.scenario import Scenario, ScenarioError, SceneObject
from sim_bridge.scenario_files import load_scenario, scenario_from_spec
from sim_bridge.sim import Sim
from sim_bridge.sim_config import SimConfig

BOX_CENTRE, BOX_HALF = np.array([0.55, 0.0, 0.1]), np.array([0.08, 0.12, 0.1])
BOX = Scenario(
    name="box", objects=(SceneObject(name="box", type="box", position=tuple(BOX_CENTRE), half_extents=tuple(BOX_HALF)),)
)
SMALL = CameraConfig(width=160, height=120, fovy=50.0, voxel_size=0.01, depth_noise=0.002)
FRONT = CameraConfig(**{**SMALL.__dict__, "position": (1.5, 0.0, 0.6), "look_at": (0.55, 0.0, 0.1)})
SIDE = CameraConfig(**{**SMALL.__dict__, "position": (0.55, -1.0, 0.6), "look_at": (0.55, 0.0, 0.1)})


@pytest.fixture
def sims():
    made = []

    def make(scenario, config, cameras=None):
        sim = Sim(scenario, config, cameras)
        made.append(sim)
        return sim

    yield make
    for sim in made:
        sim.close()


def box_distance(points: np.ndarray) -> np.ndarray:
    """Unsigned distance [m] (N,) from points (N, 3) to the surface of the box."""
    q = np.abs(points - BOX_CENTRE) - BOX_HALF
    outside = np.linalg.norm(np.maximum(q, 0.0), axis=1)
    inside = np.minimum(q.max(axis=1), 0.0)
    return np.abs(outside + inside)


def test_the_default_rig_is_the_one_camera():
    rig = camera_rig(SimConfig(), load_scenario("tabletop"))
    assert [(c.name, c.points_topic, c.pose_topic) for c in rig] == [("camera", "camera/points", "camera/pose")]
    assert rig[0].config == SimConfig().camera


def test_listed_cameras_come_from_their_parameters_over_the_camera_group():
    config = from_params(SimConfig, {"cameras": ["camera", "left"], "camera.width": 200})
    left = camera_from_params("left", {"left.position": [0.4, -1.1, 1.0], "seed": 3}, base=config.camera)
    assert left.width == 200 and left.position == (0.4, -1.1, 1.0)
    rig = camera_rig(config, None, {"left": left})
    assert [c.name for c in rig] == ["camera", "left"] and rig[1].config == left
    assert camera_params("left", left)["left.position"] == [0.4, -1.1, 1.0]
    with pytest.raises(ConfigError, match=r"left\.fovy"):
        camera_from_params("left", {"left.fovy": -1.0}, base=config.camera)
    for bad in (["camera", "camera"], [], ["seed"], ["no/slash"], "camera"):
        with pytest.raises(ConfigError, match="cameras"):
            from_params(SimConfig, {"cameras": bad})


def test_scenario_cameras_follow_the_listed_ones_unless_switched_off():
    shelf = load_scenario("shelf")
    assert [name for name, _ in shelf.cameras] == ["shelf_front", "shelf_side"]
    rig = camera_rig(SimConfig(), shelf)
    assert [(c.name, c.source) for c in rig] == [
        ("camera", "parameters"), ("shelf_front", "scenario"), ("shelf_side", "scenario")
    ]  # fmt: skip
    assert rig[1].config.position == (1.3, -0.2, 0.22) and rig[1].config.width == SimConfig().camera.width
    assert [c.name for c in camera_rig(SimConfig(scenario_cameras=False), shelf)] == ["camera"]
    listed = from_params(SimConfig, {"cameras": ["camera", "shelf_side"]})
    rig = camera_rig(listed, shelf, {"shelf_side": FRONT})
    assert [c.name for c in rig] == ["camera", "shelf_side", "shelf_front"] and rig[1].config == FRONT
    with pytest.raises(ScenarioError, match=r"cameras\.bad\.fovy"):
        scenario_from_spec({"name": "x", "cameras": {"bad": {"fovy": -3}}}, seed=0)
    with pytest.raises(ScenarioError, match="not a ROS name"):
        scenario_from_spec({"name": "x", "cameras": {"a/b": {}}}, seed=0)


def test_each_camera_has_its_cloud_and_the_fused_cloud_lies_on_the_box(sims):
    config = SimConfig(cameras=("camera", "side"), camera=FRONT, seed=1)
    sim = sims(BOX, config, {"side": SIDE})
    assert sim.camera_names == ("camera", "side")
    fusion = CloudFusion(["camera/points", "side/points"])
    for name in sim.camera_names:
        position, quaternion = sim.camera_pose(name)
        fusion.add_pose(f"{name}/points", position, "world", 0.0)
        fusion.add_cloud(f"{name}/points", sim.point_cloud(name), "world", 0.0)
    np.testing.assert_allclose(sim.camera_pose("side")[0], SIDE.position, atol=1e-9)
    fused = fusion.fuse()
    assert fused.sources == ("camera/points", "side/points") and min(fused.counts) > 100
    above = fused.points[:, 2] > 0.01  # the rest is table
    on_box = fused.points[above]
    d = box_distance(on_box)
    assert np.percentile(d, 99) < 0.012 and d.max() < 0.03, "within noise and the 1 cm voxel of the surface"
    # both cameras saw the box, each its own faces: the front one x = 0.63, the side one y = -0.12
    origins = fused.origins[above]
    from_front = on_box[np.all(origins == FRONT.position, axis=1)]
    from_side = on_box[np.all(origins == SIDE.position, axis=1)]
    assert len(from_front) > 50 and len(from_side) > 50
    assert np.sum(np.abs(from_front[:, 0] - 0.63) < 0.01) > 20 and np.sum(np.abs(from_side[:, 1] + 0.12) < 0.01) > 20
    assert np.sum(np.abs(from_front[:, 1] + 0.12) < 0.005) < np.sum(np.abs(from_side[:, 1] + 0.12) < 0.005)
    with pytest.raises(KeyError, match="no depth camera 'top'"):
        sim.point_cloud("top")


def test_the_first_camera_is_unchanged_by_more_cameras(sims):
    one = sims(BOX, SimConfig(camera=FRONT, seed=2))
    two = sims(BOX, SimConfig(cameras=("camera", "side"), camera=FRONT, seed=2), {"side": SIDE})
    np.testing.assert_array_equal(one.point_cloud(), two.point_cloud("camera"))


def test_each_camera_is_due_at_its_own_rate(sims):
    side = CameraConfig(**{**SIDE.__dict__, "rate": 5.0})
    config = SimConfig(cameras=("camera", "side"), camera=FRONT, cloud_rate=10.0, real_time_factor=0.0)
    runner = Runner(sims(BOX, config, {"side": side}))
    due = {"camera": 0, "side": 0}
    for _ in range(99):  # t = 0.01 .. 0.99 s at 100 Hz
        for name in runner.advance().clouds_due:
            due[name] += 1
    assert due == {"camera": 10, "side": 5}

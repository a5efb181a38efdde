"""Goals hidden just behind an observed surface (planning/goal_visibility.py) and their refusal by the closed loop."""

import numpy as np
import pytest

from latent_planner_ros.data.camera import CameraIntrinsics, look_at
from latent_planner_ros.data.obstacles import Box
from latent_planner_ros.data.render import depth_to_points, render_depth
from latent_planner_ros.data.scene import Scene
from latent_planner_ros.perception.cloud_fusion import camera_eyes
from latent_planner_ros.planning.amp_ls import AmpLs, AmpLsConfig
from latent_planner_ros.planning.closed_loop import ClosedLoopConfig, ClosedLoopController
from latent_planner_ros.planning.geometric_backend import GeometricBackend
from latent_planner_ros.planning.goal import Goal
from latent_planner_ros.planning.goal_visibility import goal_view

CENTRE = np.array([0.5, 0.0, 0.12])
BOX = Box(position=tuple(CENTRE), quaternion_xyzw=(0.0, 0.0, 0.0, 1.0), half_extents=(0.06, 0.06, 0.06))
FRONT = np.array([1.6, 0.0, 0.5])  # a camera in front of the box (+x), looking at it
SIDE = np.array([0.5, -1.2, 0.35])  # one on its -y side


def _view(eye: np.ndarray, scene: Scene) -> np.ndarray:
    """The points (N, 3) [m] a depth camera at `eye` sees of the scene's box and the table."""
    pose = look_at(eye, CENTRE)
    depth = render_depth(scene, pose, CameraIntrinsics(), table=True)
    return depth_to_points(depth, pose, CameraIntrinsics())


@pytest.fixture(scope="module")
def views():
    scene = Scene(obstacles=(BOX,))
    return {"front": _view(FRONT, scene), "side": _view(SIDE, scene)}


def test_a_goal_at_the_centre_of_an_object_is_hidden(views):
    v = goal_view(CENTRE, views["front"], FRONT[None], depth_m=0.08)
    assert v.hidden and v.hidden_by == 1 and v.seen_through == 0
    assert 0.05 < v.depth_m < 0.07  # the box's front face is 6 cm before its centre
    assert not goal_view(CENTRE, views["front"], FRONT[None], depth_m=0.04).hidden  # deeper than 4 cm


def test_goals_in_front_of_or_above_the_object_are_not_hidden(views):
    for goal in (CENTRE + [0.10, 0.0, 0.0], CENTRE + [0.0, 0.0, 0.10]):
        v = goal_view(goal, views["front"], FRONT[None], depth_m=0.08)
        assert not v.hidden and v.seen_through == 1  # the table behind it was seen


def test_a_goal_another_camera_sees_past_is_not_hidden(views):
    behind = CENTRE + [-0.09, 0.0, 0.0]  # 3 cm behind the box's back face, seen from the front: hidden
    front_only = goal_view(behind, views["front"], FRONT[None], depth_m=0.2)
    assert front_only.hidden
    both = goal_view(behind, np.vstack([views["front"], views["side"]]), np.stack([FRONT, SIDE]), depth_m=0.2)
    assert not both.hidden and both.hidden_by == 1 and both.seen_through == 1


def test_unknown_cameras_hide_nothing(views):
    assert not goal_view(CENTRE, views["front"], np.full((1, 3), np.nan), depth_m=0.08).hidden
    assert not goal_view(CENTRE, views["front"], np.zeros((0, 3)), depth_m=0.08).hidden
    assert camera_eyes(np.full((4, 3), np.nan)) is None
    eyes = camera_eyes(np.array([FRONT, FRONT + 1e-5, SIDE, [np.nan] * 3]))
    np.testing.assert_allclose(eyes, np.stack([SIDE, FRONT]), atol=1e-3)  # one per camera, NaN rows left out


def test_camera_eyes_equals_the_distinct_rounded_origins_in_any_order():
    rng = np.random.default_rng(3)
    cams = rng.uniform(-2, 2, (4, 3))
    for order in ("runs", "shuffled"):
        origins = np.repeat(cams, [500, 3, 1, 800], axis=0)
        if order == "shuffled":
            origins = rng.permutation(origins)
        np.testing.assert_array_equal(camera_eyes(origins), np.unique(np.round(origins, 3), axis=0))


def _controller(vae, **cfg):
    planner = AmpLs(vae, GeometricBackend(), AmpLsConfig(collision_backend="geometric"))
    return ClosedLoopController(planner, ClosedLoopConfig(**cfg))


def test_the_closed_loop_refuses_a_hidden_goal_with_a_reason(shipped_vae, views):
    goal = Goal(CENTRE, np.diag([1.0, -1.0, -1.0]))
    c = _controller(shipped_vae)
    c.set_cloud(views["front"], 0.0)  # cameras unknown: the clearance rule alone (6 cm: taken)
    assert c.check_goal(goal) == (True, "")
    c.set_cloud(views["front"], 0.0, eyes=FRONT[None])
    ok, reason = c.check_goal(goal)
    assert not ok and "hidden 6 cm behind an observed surface from 1 camera(s)" in reason
    assert not c.set_goal(goal, 0.0)[0] and c.goal is None
    above = Goal(CENTRE + [0.0, 0.0, 0.12], np.diag([1.0, -1.0, -1.0]))
    assert c.set_goal(above, 0.0)[0]
    off = _controller(shipped_vae, goal_hidden_m=0.0)
    off.set_cloud(views["front"], 0.0, eyes=FRONT[None])
    assert off.check_goal(goal) == (True, "")
    with pytest.raises(ValueError, match="goal_hidden_m"):
        ClosedLoopConfig(goal_hidden_m=-0.1)

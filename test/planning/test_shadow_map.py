"""Space no camera has seen (planning/shadow_map.py) and the RRT escape's search in seen space."""

import numpy as np
import pytest

from latent_planner_ros.planning.amp_ls import AmpLs, AmpLsConfig
from latent_planner_ros.planning.amp_ls.config import with_overrides
from latent_planner_ros.planning.geometric_backend import GeometricBackend, GeometricBackendConfig
from latent_planner_ros.planning.ompl_baseline import seed_ompl
from latent_planner_ros.planning.shadow_map import DEPTH_M, HiddenArm, ShadowMap
from latent_planner_ros.robot.limits import Q_READY
from test.planning.test_escape import GOAL_Q, _goal_of, _wall


def _plane_x(x: float, half: float = 0.5, step: float = 0.005) -> np.ndarray:
    """A square of points (N, 3) [m] in the plane x = const, centred on y = 0, z = 0.5."""
    s, h = np.meshgrid(np.arange(-half, half, step), np.arange(-half, half, step))
    return np.stack([np.full(s.size, x), s.ravel(), 0.5 + h.ravel()], 1)


EYE_A = np.array([2.0, 0.0, 0.5])  # looks along -x at the wall
EYE_B = np.array([0.0, 2.0, 0.5])  # looks along -y, past the wall's side


def test_a_point_behind_an_observed_wall_is_hidden_and_one_in_front_or_beside_it_is_not():
    shadow = ShadowMap(_plane_x(1.0), EYE_A)
    assert shadow.views == 1
    behind = np.array([[0.5, 0.0, 0.5], [0.9, 0.2, 0.6], [1.0 - 2 * DEPTH_M, -0.3, 0.3]])
    front = np.array([[1.5, 0.0, 0.5], [1.0 - DEPTH_M / 2, 0.0, 0.5]])
    beside = np.array([[0.5, 1.5, 0.5], [0.5, 0.0, 2.0]])  # rays that pass the wall's edges
    assert shadow.hidden(behind).all()
    assert not shadow.hidden(front).any()
    assert not shadow.hidden(beside).any()


def test_a_second_camera_that_sees_past_the_wall_clears_its_shadow():
    wall = _plane_x(1.0, half=0.2)
    point = np.array([[0.5, 0.0, 0.5]])  # behind the wall for A, in open view for B
    assert ShadowMap(wall, EYE_A).hidden(point).all()
    floor = np.stack(np.meshgrid(np.arange(-1, 1, 0.01), np.arange(-1, 1, 0.01)), -1).reshape(-1, 2)
    floor = np.concatenate([floor, np.zeros((len(floor), 1))], 1)  # what B sees: a floor beyond the point
    fused = ShadowMap(np.concatenate([wall, floor]), np.stack([EYE_A, EYE_B]))
    assert fused.views == 2
    assert not fused.hidden(point).any()
    # every observed point is a surface that blocks every camera, whichever camera saw it
    assert ShadowMap(wall, np.stack([EYE_A, [2.0, 0.3, 0.5]])).hidden([[0.5, 0.1, 0.5]]).all()


def test_gaps_of_one_cell_between_samples_do_not_open_the_surface():
    sparse = _plane_x(1.0, step=0.015)  # about 1.5 cells apart at 1 m
    grid = np.stack(np.meshgrid(np.linspace(-0.3, 0.3, 31), np.linspace(0.2, 0.8, 31)), -1).reshape(-1, 2)
    behind = np.concatenate([np.full((len(grid), 1), 0.4), grid], 1)
    assert ShadowMap(sparse, EYE_A).hidden(behind).all()


def test_no_points_or_no_camera_hides_nothing_and_bad_origins_are_refused():
    assert not ShadowMap(np.zeros((0, 3)), EYE_A).hidden(np.zeros((3, 3))).any()
    nan = _plane_x(1.0)
    nan[::2] = np.nan
    assert ShadowMap(nan, EYE_A).hidden(np.array([[0.5, 0.0, 0.5]])).all()  # the finite half still blocks
    with pytest.raises(ValueError, match="eyes"):
        ShadowMap(_plane_x(1.0), np.zeros((5, 2)))


def test_the_arm_behind_a_wall_is_hidden_and_in_front_of_it_is_not():
    # a wall 1.2 m in front of the robot, seen from beyond it: the whole arm is behind it
    wall = _plane_x(1.2, half=1.0, step=0.01)
    arm = HiddenArm(ShadowMap(wall, EYE_A + [1.0, 0.0, 0.0]))
    assert arm.hidden(np.stack([Q_READY, GOAL_Q])).all()
    # the same wall behind the robot, seen from in front: the arm is in plain view
    clear = HiddenArm(ShadowMap(wall - [2.0, 0.0, 0.0], EYE_A))
    assert not clear.hidden(np.stack([Q_READY, GOAL_Q])).any()


def _wall_scene():
    """The goal of GOAL_Q, the wall before it (test_escape), the wall's centre (3,) and its unit normal towards the
    goal (3,) [m]."""
    goal = _goal_of(GOAL_Q)
    wall = _wall(goal)
    centre = wall.mean(axis=0)
    normal = goal.position - centre
    return goal, wall, centre, normal / np.linalg.norm(normal)


def _escape_planner(vae, overrides: dict) -> AmpLs:
    """AMP-LS on the geometric backend with a distance field (the latent search stalls at the wall, test_escape)
    and the escape 0.3 s in (time to spare for its seen-space search on a loaded machine), with overrides."""
    base = {"collision_backend": "geometric", "escape.after_s": 0.3, "escape.seen_share": 1.0}
    field = GeometricBackend(GeometricBackendConfig(distance="field"))
    return AmpLs(vae, field, with_overrides(AmpLsConfig(), {**base, **overrides}))


def test_the_escape_searches_seen_space_first_and_its_path_stays_there(shipped_vae):
    """A wall between the ready pose and the goal, seen by one camera from the start's side, off to one side: the
    escape's path (shortcut included) keeps every sphere centre of the arm out of the wall's shadow; with
    seen_share 0 it is not asked."""
    seed_ompl(1)
    goal, wall, centre, normal = _wall_scene()
    side = np.cross(normal, [0, 0, 1.0])
    eye = centre - 1.2 * side / np.linalg.norm(side) - 0.4 * normal + [0, 0, 0.3]  # start and goal in view
    planner = _escape_planner(shipped_vae, {"escape.budget_s": 3.0})
    result = planner.plan(Q_READY, goal, wall, eye)
    assert result.success and result.reason == "reached (escape: rrt)", result.reason
    assert result.info["escape_seen_only"]
    arm = HiddenArm(ShadowMap(wall, eye))
    assert not arm.hidden(result.q_path).any()
    off = _escape_planner(shipped_vae, {"escape.budget_s": 3.0, "escape.seen_share": 0})
    result = off.plan(Q_READY, goal, wall, eye)
    assert result.success and not result.info["escape_seen_only"]


def test_seen_share_out_of_range_is_refused():
    with pytest.raises(ValueError, match="seen_share"):
        with_overrides(AmpLsConfig(), {"escape.seen_share": 1.5})


def test_the_escape_builds_one_shadow_map_per_scene_and_none_without_cameras(shipped_vae):
    planner = AmpLs(shipped_vae, GeometricBackend(), AmpLsConfig(collision_backend="geometric"))
    escape = planner.escape
    assert escape is not None
    escape.set_scene(_plane_x(1.0), EYE_A)
    arm = escape.hidden_arm()
    assert arm is not None and arm.shadow is not None and arm.shadow.views == 1
    first = arm.shadow
    assert escape.hidden_arm() is arm and arm.shadow is first  # asked again in the same scene: kept
    per_point = np.repeat(np.stack([EYE_A, EYE_B]), 2000, axis=0)  # per-point origins of two cameras
    escape.set_scene(_plane_x(1.2)[:4000], per_point)
    assert escape.hidden_arm() is arm and arm.shadow is not first and arm.shadow.views == 2
    escape.set_scene(_plane_x(1.0), None)
    assert escape.hidden_arm() is None
    assert not HiddenArm().hidden(Q_READY[None]).any()  # no shadow map: nothing hidden


def test_a_deeper_seen_space_search_runs_before_the_hard_check_alone(shipped_vae):
    """The camera looks at the wall from the goal's side, so the start's arm lies in the wall's shadow: the
    seen-space search at 2 cm finds no path and says why; with a fallback depth the arm may lie beyond (3 m:
    everything here), the path is found in seen space at that depth."""
    seed_ompl(1)
    goal, wall, centre, normal = _wall_scene()
    eye = centre + 1.5 * normal + [0, 0, 0.2]  # behind the goal, looking back at the wall
    assert HiddenArm(ShadowMap(wall, eye)).hidden(Q_READY[None])[0]
    plain = _escape_planner(shipped_vae, {"escape.budget_s": 1.5})
    result = plain.plan(Q_READY, goal, wall, eye)
    assert result.success and not result.info["escape_seen_only"], result.reason
    assert result.info["escape_seen_note"].startswith("2 cm: "), result.info["escape_seen_note"]
    planner = _escape_planner(shipped_vae, {"escape.budget_s": 1.5, "escape.fallback_depths_m": [3.0]})
    result = planner.plan(Q_READY, goal, wall, eye)
    assert result.success and result.info["escape_seen_only"], result.reason
    assert result.info["escape_seen_depth_m"] == 3.0 and "escape_seen_note" not in result.info


@pytest.mark.parametrize("depths", [[0.0], [-0.1], [float("nan")], "0.1"])
def test_bad_fallback_depths_are_refused(depths):
    with pytest.raises(ValueError, match="fallback_depths_m"):
        with_overrides(AmpLsConfig(), {"escape.fallback_depths_m": depths})

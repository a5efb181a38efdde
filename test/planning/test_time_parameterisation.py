"""Jerk-limited time parameterisation (ruckig): at rest at both ends, within the limits, on the checked path."""

import numpy as np
import pytest

from latent_planner_ros.planning.motion_limits import MotionLimits
from latent_planner_ros.planning.ruckig_segments import polyline_deviation
from latent_planner_ros.planning.time_parameterisation import jerk_limited_trajectory, merge_collinear
from latent_planner_ros.robot.limits import A_MAX, J_MAX, Q_READY, V_MAX

DT = 1e-3


def within_limits(traj, limits: MotionLimits, dt: float = DT) -> None:
    """Velocities, accelerations and finite-difference jerk of a trajectory sampled every dt are within limits."""
    assert np.all(np.diff(traj.times) > 0)
    assert np.all(np.abs(traj.velocities) <= limits.v_max * (1 + 1e-6))
    assert np.all(np.abs(traj.accelerations) <= limits.a_max * (1 + 1e-6))
    inner = np.diff(traj.times)[:-1]  # the last step may be shorter
    assert np.allclose(inner, dt, atol=1e-9)
    n = len(inner) + 1
    jerk_from_acc = np.diff(traj.accelerations[:n], axis=0) / dt
    assert np.all(np.abs(jerk_from_acc) <= limits.j_max * (1 + 1e-6) + 1e-6)
    jerk_from_q = np.diff(traj.positions[:n], n=3, axis=0) / dt**3
    assert np.all(np.abs(jerk_from_q) <= limits.j_max * (1 + 1e-3) + 1e-3)
    vel_from_q = np.diff(traj.positions[:n], axis=0) / dt
    assert np.all(np.abs(vel_from_q) <= limits.v_max * (1 + 1e-3))


def smooth_path(rng, n=40, step=0.04, noise=0.05) -> np.ndarray:
    q, d = [Q_READY.copy()], rng.normal(size=7)
    for _ in range(n):
        d = d / np.linalg.norm(d) + noise * rng.normal(size=7)
        q.append(q[-1] + step * d / np.linalg.norm(d))
    return np.array(q)


CORNERS = Q_READY + np.array(
    [
        [0.0] * 7,
        [0.8, 0.3, -0.4, 0.3, 0.2, 0.1, 0.5],
        [1.0, -0.2, 0.1, 0.6, -0.4, 0.3, 0.0],
        [0.2, 0.1, 0.0, 0.2, 0.0, 0.0, -0.3],
    ]
)


@pytest.mark.parametrize("kind", ["smooth", "corners", "straight"])
@pytest.mark.parametrize("limits", [MotionLimits(), MotionLimits(1.0, 1.0, 1.0), MotionLimits(0.2, 0.1, 0.05)])
def test_trajectory_is_at_rest_at_both_ends_within_limits_and_on_the_path(rng, kind, limits):
    path = {"smooth": smooth_path(rng), "corners": CORNERS, "straight": np.linspace(Q_READY, Q_READY + 0.6, 12)}[kind]
    traj = jerk_limited_trajectory(path, limits, dt=DT, deviation_tol_rad=0.01)
    np.testing.assert_allclose(traj.positions[0], path[0], atol=1e-12)
    np.testing.assert_allclose(traj.positions[-1], path[-1], atol=1e-6)
    for end in (0, -1):
        assert not np.any(traj.velocities[end]) and not np.any(traj.accelerations[end])
    within_limits(traj, limits)
    deviation = polyline_deviation(traj.positions, path).max()
    assert deviation <= traj.max_deviation_rad + 1e-12 and traj.max_deviation_rad <= 0.01
    assert traj.times[0] == 0 and traj.duration == traj.times[-1]


def test_waypoint_velocities_make_a_smooth_path_faster_than_stopping_at_each_waypoint(rng):
    path = smooth_path(rng)
    blended = jerk_limited_trajectory(path, deviation_tol_rad=0.01)
    exact = jerk_limited_trajectory(path, deviation_tol_rad=1e-9)  # every segment rest to rest, exactly straight
    assert exact.max_deviation_rad < 1e-9
    assert blended.duration < 0.6 * exact.duration
    speed = np.linalg.norm(blended.velocities, axis=1)
    assert np.min(speed[len(speed) // 4 : -len(speed) // 4]) > 0  # no stop in the middle


def test_straight_runs_and_corners_are_exact():
    runs = [np.linspace(a, b, 10, endpoint=False) for a, b in zip(CORNERS[:-1], CORNERS[1:], strict=True)]
    interpolated = np.concatenate(runs)
    path = np.concatenate([interpolated, CORNERS[-1:]])
    np.testing.assert_allclose(merge_collinear(path), CORNERS, atol=1e-12)
    traj = jerk_limited_trajectory(path)
    assert traj.max_deviation_rad < 1e-9
    assert traj.duration == pytest.approx(jerk_limited_trajectory(CORNERS).duration)


def test_a_single_state_or_repeated_states_give_a_single_sample():
    traj = jerk_limited_trajectory(np.stack([Q_READY] * 3))
    assert traj.times.shape == (1,) and traj.positions.shape == (1, 7) and traj.duration == 0


def test_datasheet_limits_and_scales():
    limits = MotionLimits(0.5, 0.25, 0.1)
    np.testing.assert_allclose(limits.v_max, 0.5 * V_MAX)
    np.testing.assert_allclose(limits.a_max, 0.25 * A_MAX)
    np.testing.assert_allclose(limits.j_max, 0.1 * J_MAX)
    defaults = MotionLimits()
    assert max(defaults.velocity_scale, defaults.acceleration_scale, defaults.jerk_scale) < 1


@pytest.mark.parametrize("scale", [0.0, -0.1, 1.5, float("nan")])
def test_bad_scales_are_refused(scale):
    with pytest.raises(ValueError, match="jerk_scale"):
        MotionLimits(jerk_scale=scale)


@pytest.mark.parametrize("path", [np.zeros((0, 7)), np.zeros((3, 6)), np.full((2, 7), np.nan)])
def test_bad_paths_are_refused(path):
    with pytest.raises(ValueError, match="q_path"):
        jerk_limited_trajectory(path)

"""The message adapters as fuzzing boundaries: each converts a generated message and checks what it gives back.

A boundary's `check(msg)` returns "accepted" or "refused"; it raises :class:`InvariantError` when an accepted
result breaks the adapter's contract (shape, finiteness, unit quaternion, ...) or a refusal carries no reason, and
lets any other exception than AdapterError escape (that is the finding). Used by test/fuzz and `bench fuzz`.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
from hypothesis import strategies as st

from latent_planner_ros.bench import fuzz_strategies as fs
from latent_planner_ros.nodes.frames_config import FramesConfig
from msg_adapters import (
    AdapterError,
    apply_marker_array,
    cloud_to_embedding,
    cloud_to_fields,
    cloud_to_xyz,
    joint_state_to_q,
    plan_tolerance,
    pose_stamped_to_target,
    trajectory_to_arrays,
    trajectory_to_execution,
)
from msg_adapters.pose import pose_stamped_in_base

ACCEPTED, REFUSED = "accepted", "refused"


class InvariantError(AssertionError):
    """A boundary broke its contract without raising (a bad result, or a refusal without a reason)."""


@dataclass(frozen=True)
class Boundary:
    """One input boundary: a name, the strategy of its inputs, and the check of one input."""

    name: str
    strategy: st.SearchStrategy
    check: Callable[[Any], str]


def refusal(fn: Callable, *args) -> tuple[Any, str | None]:
    """(result, None), or (None, reason) for an AdapterError; InvariantError for an empty reason."""
    try:
        return fn(*args), None
    except AdapterError as err:
        if not str(err).strip():
            raise InvariantError(f"{fn.__name__} refused without a reason") from err
        return None, str(err)


def expect(condition: bool, text: str) -> None:
    if not condition:
        raise InvariantError(text)


def _finite(a: np.ndarray, what: str) -> None:
    expect(bool(np.all(np.isfinite(a))), f"{what} has NaN or inf")


def _joint_state(msg) -> str:
    out, reason = refusal(joint_state_to_q, msg)
    if reason:
        return REFUSED
    q, dq = out
    expect(q.shape == (7,), f"q shape {q.shape}")
    _finite(q, "q")
    if dq is not None:
        expect(dq.shape == (7,), f"dq shape {dq.shape}")
        _finite(dq, "dq")
    return ACCEPTED


def _cloud(msg) -> str:
    pts, reason = refusal(cloud_to_xyz, msg)
    if reason:
        return REFUSED
    expect(pts.ndim == 2 and pts.shape[1] == 3 and pts.dtype == np.float32, f"points {pts.shape} {pts.dtype}")
    expect(len(pts) <= int(msg.width) * int(msg.height), f"{len(pts)} points from {msg.width} x {msg.height}")
    _finite(pts, "points")
    return ACCEPTED


def _cloud_fields(msg) -> str:
    names = [f.name for f in msg.fields][:5] or ["x"]
    values, reason = refusal(cloud_to_fields, msg, names)
    if reason:
        return REFUSED
    expect(values.shape[1:] == (len(names),), f"values {values.shape} for {names}")
    _finite(values, "values")
    return ACCEPTED


def _embedding(msg) -> str:
    out, reason = refusal(cloud_to_embedding, msg)
    if reason:
        return REFUSED
    centres, features = out
    expect(len(centres) == len(features) == int(msg.width) * int(msg.height), "voxels lost")
    expect(centres.shape[1:] == (3,) and features.ndim == 2 and features.shape[1] >= 1, "shapes")
    _finite(centres, "centres")
    _finite(features, "features")
    return ACCEPTED


def _check_target(target) -> None:
    _finite(target.position, "position")
    expect(abs(float(np.linalg.norm(target.quaternion_xyzw)) - 1.0) < 1e-6, f"quaternion {target.quaternion_xyzw}")
    r = target.rotation
    expect(bool(np.allclose(r @ r.T, np.eye(3), atol=1e-6)) and abs(np.linalg.det(r) - 1.0) < 1e-6, "rotation")


def _pose(msg) -> str:
    target, reason = refusal(pose_stamped_to_target, msg)
    if reason:
        return REFUSED
    _check_target(target)
    expect(target.frame_id == "world", f"frame {target.frame_id!r}")
    return ACCEPTED


_FRAMES = FramesConfig(extrinsics="camera_depth_optical_frame: 0.5 0 1 3.14159 0 0").frames()


def _pose_in_base(msg) -> str:
    target, reason = refusal(pose_stamped_in_base, msg, _FRAMES)
    if reason:
        return REFUSED
    _check_target(target)
    return ACCEPTED


def _plan_request(request) -> str:
    tol, reason = refusal(plan_tolerance, request.tolerance, 0.01)
    if reason:
        return REFUSED
    expect(np.isfinite(tol) and tol > 0, f"tolerance {tol}")
    return _pose_in_base(request.goal)


def _markers(msg) -> str:
    update, reason = refusal(apply_marker_array, msg, None)
    if reason:
        return REFUSED
    for key, cyl in update.cylinders.items():
        expect(cyl.shape == (4,) and bool(np.all(np.isfinite(cyl))), f"cylinder {key}: {cyl}")
        expect(cyl[2] > 0 and cyl[3] > 0, f"cylinder {key}: height and radius {cyl[2:]}")
    return ACCEPTED


def _trajectory(msg) -> str:
    arrays, reason = refusal(trajectory_to_arrays, msg)
    if arrays is not None:
        q, t = arrays
        expect(q.shape == (len(msg.points), 7) and t.shape == (len(msg.points),), "trajectory shapes")
    out, reason = refusal(trajectory_to_execution, msg)
    if reason:
        return REFUSED
    times, q, dq, ddq = out
    expect(len(times) >= 1 and bool(np.all(np.diff(times) > 0)) and times[0] >= 0, f"times {times}")
    for a, what in ((q, "positions"), (dq, "velocities"), (ddq, "accelerations")):
        if a is not None:
            expect(a.shape == (len(times), 7), f"{what} shape {a.shape}")
            _finite(a, what)
    return ACCEPTED


ADAPTER_BOUNDARIES = (
    Boundary("joint_state_to_q", fs.joint_states(), _joint_state),
    Boundary("cloud_to_xyz", fs.point_clouds(), _cloud),
    Boundary("cloud_to_fields", fs.point_clouds(), _cloud_fields),
    Boundary("cloud_to_embedding", fs.embedding_clouds(), _embedding),
    Boundary("pose_stamped_to_target", fs.pose_stampeds(), _pose),
    Boundary("pose_stamped_in_base", fs.pose_stampeds(), _pose_in_base),
    Boundary("plan_request", fs.plan_requests(), _plan_request),
    Boundary("apply_marker_array", fs.marker_arrays(), _markers),
    Boundary("trajectory_to_execution", fs.joint_trajectories(), _trajectory),
)
"""Every adapter that converts an incoming message."""

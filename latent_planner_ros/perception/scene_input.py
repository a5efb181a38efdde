"""What the scene_encoder node does to a cloud before encoding it, and the state it reports. No ROS.

prepare_cloud: drop non-finite points, crop to the encoder's workspace box, and voxel-downsample clouds
larger than max_points (so encoding time stays bounded). SceneInputMonitor: the node's status (OK, WARN
for an empty or stale input, ERROR for a refused cloud) as a level, a message and key-values.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from latent_planner_ros.data.cloud_ops import voxel_downsample

OK, WARN, ERROR = 0, 1, 2
"""Diagnostic levels (as in diagnostic_msgs/DiagnosticStatus)."""

MIN_VOXEL_GROWTH = 1.2
"""Least factor by which the downsampling voxel grows while a cloud still has more than max_points points."""
MAX_VOXEL_TRIES = 8


@dataclass(frozen=True)
class PreparedCloud:
    """A cloud ready for the encoder.

    Attributes:
        points: (M, 3) float32 [m] in `world`, finite, inside [bounds_min, bounds_max), M <= max_points.
        points_in: points received (N of the (N, 3) input, non-finite ones included).
        points_finite: of those, points with finite coordinates.
        points_inside: of those, points inside the workspace bounds.
        voxel_m: edge [m] of the downsampling voxel used; 0 when the cloud was small enough as it was.
        origins: (M, 3) float64 [m] in `world`, the camera origin of each point (NaN rows: unknown), when the
            cloud came with per-point origins; else None.
    """

    points: np.ndarray
    points_in: int
    points_finite: int
    points_inside: int
    voxel_m: float = 0.0
    origins: np.ndarray | None = None

    @property
    def points_used(self) -> int:
        return len(self.points)


def inside_bounds(points: np.ndarray, bounds_min, bounds_max) -> np.ndarray:
    """(N,) bool: which points (N, 3) [m] are inside the half-open box [bounds_min, bounds_max), compared in
    float32 as the encoder does."""
    low, high = np.asarray(bounds_min, dtype=np.float32), np.asarray(bounds_max, dtype=np.float32)
    p = np.asarray(points).astype(np.float32, copy=False)
    inside = np.ones(len(p), dtype=bool)
    for axis in range(3):  # column by column: np.all(..., axis=1) is slow on rows of 3
        inside &= (p[:, axis] >= low[axis]) & (p[:, axis] < high[axis])
    return inside


def crop_to_bounds(points: np.ndarray, bounds_min, bounds_max) -> np.ndarray:
    """The points (N, 3) [m] inside the half-open box [bounds_min, bounds_max) (the voxels the encoder sees)."""
    return points[inside_bounds(points, bounds_min, bounds_max)]


def limit_points(points: np.ndarray, max_points: int, voxel: float) -> tuple[np.ndarray, float]:
    """At most max_points of points (M, 3) [m], and the voxel edge [m] used (0 = unchanged).

    Clouds above max_points are voxel-downsampled (one point per occupied voxel, the mean of its points, as
    in the sim's camera and collision training) with edge `voxel`, grown until they fit: by sqrt(M / max_points)
    (right for surfaces, whose point count goes as 1 / edge^2), at least by MIN_VOXEL_GROWTH. If they still do
    not fit after MAX_VOXEL_TRIES (or voxel is 0), evenly spaced points are kept.
    """
    if len(points) <= max_points:
        return points, 0.0
    out, used = points, 0.0
    if voxel > 0.0:
        size = voxel
        for _ in range(MAX_VOXEL_TRIES):
            out, used = voxel_downsample(points, size).astype(np.float32), size
            if len(out) <= max_points:
                return out, used
            size *= max(MIN_VOXEL_GROWTH, float(np.sqrt(len(out) / max_points)))
    keep = np.linspace(0, len(out) - 1, max_points).round().astype(np.int64)
    return out[keep], used


def origin_groups(origins: np.ndarray) -> np.ndarray:
    """The camera index (M,) of each of per-point origins (M, 3) [m]: what `np.unique(origins, axis=0,
    return_inverse=True)` gives (NaN rows one group, last), in O(M) for a fused cloud, whose points come in one
    run per camera (the sort is of the runs' first rows only; np.unique of 27k rows took about 60 ms here)."""
    key = np.nan_to_num(np.asarray(origins, dtype=np.float64).reshape(-1, 3), nan=np.inf)
    if not len(key):
        return np.zeros(0, dtype=np.int64)
    first = np.flatnonzero(np.r_[True, np.any(key[1:] != key[:-1], axis=1)])
    _, run_group = np.unique(key[first], axis=0, return_inverse=True)
    return np.repeat(run_group.reshape(-1), np.diff(np.r_[first, len(key)]))


def limit_points_by_origin(
    points: np.ndarray, origins: np.ndarray, max_points: int, voxel: float
) -> tuple[np.ndarray, np.ndarray, float]:
    """:func:`limit_points` for a cloud with one origin per point: each camera's points (same origin row; NaN
    rows form one group) are downsampled on their own, so every kept point keeps its camera's origin.

    Args:
        points: (M, 3) [m]; origins: (M, 3) [m] aligned with points.
    Returns:
        points (K, 3) float32, their origins (K, 3) float64, and the voxel edge [m] used (0 = unchanged).
        With one origin for all points, the points are exactly those of :func:`limit_points`.
    """
    if len(points) <= max_points:
        return points, origins, 0.0
    group = origin_groups(origins)
    members = [np.flatnonzero(group.reshape(-1) == g) for g in range(int(group.max()) + 1)]
    out, out_origins, used = points, origins, 0.0
    if voxel > 0.0:
        size = voxel
        for _ in range(MAX_VOXEL_TRIES):
            parts = [voxel_downsample(points[m], size).astype(np.float32) for m in members]
            out = np.concatenate(parts)
            rows = [np.broadcast_to(origins[m[0]], p.shape) for m, p in zip(members, parts, strict=True)]
            out_origins = np.concatenate(rows)
            used = size
            if len(out) <= max_points:
                return out, out_origins.astype(np.float64), used
            size *= max(MIN_VOXEL_GROWTH, float(np.sqrt(len(out) / max_points)))
    keep = np.linspace(0, len(out) - 1, max_points).round().astype(np.int64)
    return out[keep], np.asarray(out_origins, dtype=np.float64)[keep], used


def prepare_cloud(
    points: np.ndarray,
    bounds_min,
    bounds_max,
    max_points: int,
    voxel: float,
    points_in: int | None = None,
    origins: np.ndarray | None = None,
) -> PreparedCloud:
    """Filter, crop and bound a cloud for the encoder.

    Args:
        points: (N, 3) [m] in `world`, robot points removed; NaN/inf points are dropped as absent.
        bounds_min, bounds_max: (3,) [m] the encoder's workspace box; points outside it are dropped.
        max_points: clouds with more points (after cropping) are downsampled to at most this many.
        voxel: [m] edge of the first downsampling voxel (0: keep evenly spaced points instead).
        points_in: points received, when non-finite ones were already dropped upstream (default N).
        origins: (N, 3) [m] the camera origin of each point (a fused cloud), kept aligned with the points.
    Raises:
        ValueError: points is not (N, 3), or origins not of the same shape.
    """
    pts = np.asarray(points, dtype=np.float32)
    if pts.ndim != 2 or pts.shape[1] != 3:
        raise ValueError(f"points: expected shape (N, 3), got {pts.shape}")
    received = len(pts) if points_in is None else max(int(points_in), len(pts))
    if origins is None:
        finite = pts[np.all(np.isfinite(pts), axis=1)]
        inside = crop_to_bounds(finite, bounds_min, bounds_max)
        used, size = limit_points(inside, max_points, voxel)
        return PreparedCloud(np.ascontiguousarray(used, dtype=np.float32), received, len(finite), len(inside), size)
    org = np.asarray(origins, dtype=np.float64)
    if org.shape != pts.shape:
        raise ValueError(f"origins: expected shape {pts.shape} like the points, got {org.shape}")
    keep = np.all(np.isfinite(pts), axis=1)
    n_finite = int(keep.sum())
    keep &= inside_bounds(pts, bounds_min, bounds_max)
    used, used_origins, size = limit_points_by_origin(pts[keep], org[keep], max_points, voxel)
    return PreparedCloud(
        np.ascontiguousarray(used, dtype=np.float32), received, n_finite, int(keep.sum()), size,
        np.ascontiguousarray(used_origins, dtype=np.float64),
    )  # fmt: skip


@dataclass(frozen=True)
class StatusReport:
    """What the node publishes on ~/status: level (OK/WARN/ERROR), a message with the reason, key-values."""

    level: int
    state: str
    message: str
    values: dict


def _cloud_values(
    points_in: int,
    finite=0,
    inside=0,
    used=0,
    voxel_m=0.0,
    encode_ms=0.0,
    origin="none (no cloud encoded)",
    sources="",
    stale="",
) -> dict:
    """Status key-values of the last cloud: point counts, downsampling voxel [m], encoding time [ms], whether it
    was encoded with its camera origin, the cloud topics fused into it and the ones left out as stale."""
    return {
        "camera_origin": origin,
        "cloud_sources": sources,
        "clouds_stale": stale,
        "points_in": points_in,
        "points_finite": finite,
        "points_inside": inside,
        "points_used": used,
        "downsample_voxel_m": voxel_m,
        "encode_ms": encode_ms,
    }


class SceneInputMonitor:
    """The node's state from the clouds it received: waiting, ok, empty, refused, stale.

    Times are in seconds on one clock (the node's). A refused cloud is reported until the next cloud is
    encoded; any cloud, good or refused, resets the staleness timer.
    """

    def __init__(self, stale_after_s: float, topics: str = "camera/points"):
        self.stale_after_s = stale_after_s
        self.last_arrival: float | None = None
        self.state, self.level, self.message = "waiting", WARN, f"waiting for {topics}"
        self.last_error = ""
        self.encoded = 0
        self.refused = 0
        self.values = _cloud_values(points_in=0)

    def on_encoded(
        self, now: float, cloud: PreparedCloud, encode_ms: float, origin: str = "not used", sources="", stale=""
    ) -> None:
        """A cloud was encoded (and published) in encode_ms [ms]; origin says whether with its camera origin,
        sources which cloud topics were fused into it, stale which ones were left out as stale (then WARN)."""
        self.last_arrival = now
        self.encoded += 1
        self.values = _cloud_values(
            cloud.points_in, cloud.points_finite, cloud.points_inside, cloud.points_used, cloud.voxel_m, encode_ms,
            origin, sources, stale,
        )  # fmt: skip
        if cloud.points_used == 0:
            self.state, self.level = "empty", WARN
            self.message = (
                f"empty cloud: no finite points inside the workspace bounds ({cloud.points_in} received); "
                "encoded as an empty scene"
            )
        else:
            self.state, self.level = "ok", OK
            self.message = f"encoded {cloud.points_used} points"
            if cloud.voxel_m > 0.0:
                self.message += f" (downsampled from {cloud.points_inside}, voxel {cloud.voxel_m * 1000:.0f} mm)"
        if stale:
            self.level = max(self.level, WARN)
            self.message += f"; left out as stale: {stale}"

    def on_refused(self, now: float, reason: str, points_in: int = 0) -> None:
        """A cloud (of points_in points, as far as known) was refused (malformed); nothing was published."""
        self.last_arrival = now
        self.refused += 1
        self.values = _cloud_values(points_in)
        self.last_error = reason
        self.state, self.level, self.message = "refused", ERROR, reason

    def report(self, now: float) -> StatusReport:
        """The status at time now [s]."""
        state, level, message = self.state, self.level, self.message
        age = None if self.last_arrival is None else now - self.last_arrival
        if age is not None and age > self.stale_after_s:
            state, level = "stale", max(level, WARN)
            message = f"stale: no cloud for {age:.1f} s (last: {message})"
        values = {
            "state": state,
            **self.values,
            "cloud_age_s": -1.0 if age is None else age,
            "clouds_encoded": self.encoded,
            "clouds_refused": self.refused,
            "last_error": self.last_error,
        }
        return StatusReport(level, state, message, values)

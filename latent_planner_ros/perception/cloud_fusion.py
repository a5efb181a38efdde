"""Fusing the clouds of several depth cameras into one cloud in the robot base frame, with one camera origin per
point. No ROS.

Each camera publishes its own cloud topic (sensor_msgs/PointCloud2, normally in `world`) and, beside it, a pose
topic with its optical centre (`<ns>/points` and `<ns>/pose`, as the sim does; :func:`pose_topic_of`). A node keeps
a :class:`CloudFusion` over its configured cloud topics: it holds the newest accepted cloud of each topic and the
newest origin of each camera, moved into the base frame (perception/frames.py: `world`, the base frame and
configured sensor frames are accepted), refuses clouds from topics it was not configured with and clouds in any
other frame (with the same reason in every node, for its status), and :meth:`CloudFusion.fuse` concatenates the
clouds that are not stale:
a topic's cloud stamped more than `max_age_s` away from the reference stamp (the newest cloud's) is left out and
named. Each point carries the origin of its camera (NaN when the camera's pose is unknown or too far in time).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from latent_planner_ros.perception.camera_origin import CameraOrigin
from latent_planner_ros.perception.frames import FrameRefused, Frames

POSE_NAME = "pose"
"""Last token of a camera's pose topic, beside its cloud topic (`camera/points` -> `camera/pose`)."""


def camera_eyes(origins: np.ndarray) -> np.ndarray | None:
    """The distinct optical centres (K, 3) [m] among per-point origins (N, 3) [m] (rounded to 1 mm; NaN rows, of
    cameras whose pose is unknown, left out), or None when no point's origin is known."""
    origins = np.asarray(origins, dtype=float).reshape(-1, 3)
    known = origins[np.all(np.isfinite(origins), axis=1)]
    if len(known) == 0:
        return None
    rounded = np.round(known, 3)
    # a fused cloud holds each camera's points in one run: drop repeats of the row before first, then sort the
    # few left (np.unique of 40k rows alone took about 50-100 ms here)
    runs = rounded[np.r_[True, np.any(rounded[1:] != rounded[:-1], axis=1)]]
    return np.unique(runs, axis=0)


def pose_topic_of(cloud_topic: str) -> str:
    """The pose topic beside a cloud topic: its last token replaced by `pose` (`left/points` -> `left/pose`,
    `/a/b/points` -> `/a/b/pose`, `points` -> `pose`), as image_transport pairs an image with its camera_info."""
    head, sep, _ = cloud_topic.rpartition("/")
    return f"{head}{sep}{POSE_NAME}"


class CloudRefused(ValueError):
    """A cloud was not accepted; the message says which topic and why."""


@dataclass(frozen=True)
class FusedCloud:
    """The fused scene.

    Attributes:
        points: (N, 3) float32 [m] in the fusion frame (the robot base frame), the clouds of `sources` one after
            another (finite points only).
        origins: (N, 3) float64 [m] in the fusion frame: the optical centre of the camera that saw each point; NaN rows
            where that camera's origin is unknown.
        stamp_s: [s] stamp of the newest cloud used (0 when none).
        sources: the topics whose clouds were used, in configuration order.
        counts: points per used topic (same order as sources).
        stale: {topic: how far [s] its newest cloud is from stamp_s} for the topics left out as stale.
        missing: topics that have not delivered any cloud yet.
        origin_notes: {topic: status word of its origin ("known" or "unknown: ...")} for the used topics.
    """

    points: np.ndarray
    origins: np.ndarray
    stamp_s: float = 0.0
    sources: tuple[str, ...] = ()
    counts: tuple[int, ...] = ()
    stale: dict = field(default_factory=dict)
    missing: tuple[str, ...] = ()
    origin_notes: dict = field(default_factory=dict)

    def origin_summary(self) -> str:
        """One status word for the cloud's origins: "known", "unknown: <why>" or "known for K of M cameras ..."."""
        notes = [self.origin_notes[t] for t in self.sources]
        if not notes:
            return "none (no cloud)"
        if len(notes) == 1:
            return notes[0]
        known = sum(n == "known" for n in notes)
        if known == len(notes):
            return "known"
        unknown = "; ".join(f"{t}: {n}" for t, n in self.origin_notes.items() if n != "known")
        return f"known for {known} of {len(notes)} cameras ({unknown})"

    def describe(self) -> str:
        """Sources with point counts, and the stale ones: e.g. "camera/points 812, left/points 640; stale: ..."."""
        text = ", ".join(f"{t} {n}" for t, n in zip(self.sources, self.counts, strict=True)) or "none"
        if self.stale:
            text += "; stale: " + ", ".join(f"{t} ({gap:.2f} s behind)" for t, gap in self.stale.items())
        return text


@dataclass
class _Held:
    points: np.ndarray
    stamp_s: float


class CloudFusion:
    """The newest cloud of each configured topic and the newest origin of each camera, fused on demand.

    Args:
        topics: the cloud topics (names as configured, one per camera; at least one, no repeats).
        frames: the accepted frames (clouds and poses are moved into frames.base_frame); a string names the only
            frame accepted, with no transform.
        max_age_s: [s] a topic's cloud stamped further than this from the reference stamp is left out (stale);
            0 = never.
        origin_max_age_s: [s] a camera pose stamped further than this from its cloud's stamp is not used with it
            (the points' origins are then unknown); 0 = any age.

    Raises:
        ValueError: no topics, or a topic listed twice.
    """

    def __init__(self, topics: Sequence[str], frames: Frames | str = "world", max_age_s=0.5, origin_max_age_s=1.0):
        topics = tuple(topics)
        if not topics:
            raise ValueError("cloud topics: at least one is needed")
        if len(set(topics)) != len(topics):
            raise ValueError(f"cloud topics: {list(topics)} lists a topic twice")
        self.topics = topics
        self.frames = Frames(frames) if isinstance(frames, str) else frames
        self.frame_id = self.frames.base_frame
        """the frame of the fused cloud"""
        self.max_age_s = float(max_age_s)
        self._clouds: dict[str, _Held] = {}
        self._origins = {t: CameraOrigin(origin_max_age_s, pose_topic_of(t)) for t in topics}
        self._round: set[str] = set()  # topics that delivered since the last fuse()
        self.received: dict[str, int] = {}
        """points received per topic in its newest accepted cloud (non-finite ones included, when given)"""
        self.newest: str | None = None
        """The topic of the cloud accepted last."""

    def set_origin_max_age(self, seconds: float) -> None:
        """Change origin_max_age_s [s] of every camera."""
        for origin in self._origins.values():
            origin.max_age_s = float(seconds)

    def check(self, topic: str, frame_id: str) -> None:
        """CloudRefused unless topic is configured and frame_id is an accepted frame (call before converting)."""
        if topic not in self._origins:
            raise CloudRefused(f"{topic} refused: not a configured cloud topic (configured: {list(self.topics)})")
        self._to_base(topic, frame_id)

    def _to_base(self, topic: str, frame_id: str):
        try:
            return self.frames.to_base(frame_id)
        except FrameRefused as err:
            raise CloudRefused(f"{topic} refused: {err}") from None

    def add_cloud(
        self, topic: str, points: np.ndarray, frame_id: str, stamp_s: float, points_in: int | None = None
    ) -> None:
        """Keep points (N, 3) [m] in frame_id (NaN/inf rows are dropped), moved into the fusion frame, as the newest
        cloud of topic, stamped stamp_s [s];
        points_in: the points the message held, when non-finite ones were dropped upstream (default N).

        Raises:
            CloudRefused: an unknown topic, another frame, or points that are not (N, 3); the topic keeps its
                previous cloud.
        """
        self.check(topic, frame_id)
        pts = np.asarray(points, dtype=np.float32)
        if pts.ndim != 2 or pts.shape[1] != 3:
            raise CloudRefused(f"{topic} refused: expected points of shape (N, 3), got {pts.shape}")
        self.received[topic] = len(pts) if points_in is None else max(int(points_in), len(pts))
        pts = self._to_base(topic, frame_id).points(pts[np.all(np.isfinite(pts), axis=1)])
        self._clouds[topic] = _Held(pts, float(stamp_s))
        self._round.add(topic)
        self.newest = topic

    def add_pose(self, topic: str, position: np.ndarray, frame_id: str, stamp_s: float) -> None:
        """The optical centre (3,) [m] of the camera of cloud topic `topic`, stamped stamp_s [s].

        Raises:
            CloudRefused: an unknown topic, another frame, or a non-finite position (the previous origin stays).
        """
        pose_topic = pose_topic_of(topic)
        if topic not in self._origins:
            raise CloudRefused(f"{pose_topic} refused: not the pose of a configured cloud topic")
        to_base = self._to_base(pose_topic, frame_id)
        p = np.asarray(position, dtype=np.float64).reshape(-1)
        if p.shape != (3,) or not np.all(np.isfinite(p)):
            raise CloudRefused(f"{pose_topic} refused: position {p.tolist()} is not 3 finite numbers")
        p = to_base.points(p[None])[0]
        self._origins[topic].on_pose(p, stamp_s)

    def round_complete(self) -> bool:
        """Whether every topic whose cloud is not stale has delivered a cloud since the last :meth:`fuse`: a node
        that fuses only then publishes once per round of cameras, at the rate of the slowest live one; a camera
        gone silent stops holding rounds up once its cloud is stale (max_age_s behind the newest)."""
        if self.newest is None or not self._round:
            return False
        ref = self._clouds[self.newest].stamp_s
        return all(t in self._round or self._is_stale(h, ref) for t, h in self._clouds.items())

    def _is_stale(self, held: _Held, ref: float) -> bool:
        return self.max_age_s > 0.0 and abs(ref - held.stamp_s) > self.max_age_s

    def fuse(self) -> FusedCloud:
        """The fused cloud of the topics' newest clouds, the newest accepted cloud's stamp as reference; starts a
        new round (round_complete)."""
        self._round = set()
        empty = np.zeros((0, 3), dtype=np.float32)
        missing = tuple(t for t in self.topics if t not in self._clouds)
        if self.newest is None:
            return FusedCloud(empty, np.zeros((0, 3)), missing=missing)
        ref = self._clouds[self.newest].stamp_s
        points, origins, sources, counts, stale, notes = [], [], [], [], {}, {}
        newest = 0.0
        for topic in self.topics:
            held = self._clouds.get(topic)
            if held is None:
                continue
            if self._is_stale(held, ref):
                stale[topic] = abs(ref - held.stamp_s)
                continue
            origin, notes[topic] = self._origins[topic].for_cloud(held.stamp_s)
            points.append(held.points)
            row = np.full(3, np.nan) if origin is None else origin
            origins.append(np.broadcast_to(row, held.points.shape))
            sources.append(topic)
            counts.append(len(held.points))
            newest = max(newest, held.stamp_s)
        return FusedCloud(
            np.concatenate(points).astype(np.float32, copy=False),
            np.concatenate(origins).astype(np.float64),
            newest,
            tuple(sources),
            tuple(counts),
            stale,
            missing,
            notes,
        )

"""Parameters of the scene_encoder node: one dataclass, mapped 1:1 onto ROS parameters (config/scene_encoder.yaml)."""

from __future__ import annotations

from dataclasses import dataclass, field

from latent_planner_ros.nodes.frames_config import FRAMES_READ_ONLY, FramesConfig
from latent_planner_ros.params.config import MIN_RATE_HZ, ConfigError, check_int, check_number


@dataclass
class SceneEncoderNodeConfig:
    checkpoint: str = ""
    """collision checkpoint stem whose scene encoder is used; empty = the shipped default"""
    max_points: int = 50_000
    """clouds with more points inside the workspace bounds are downsampled to at most this many"""
    downsample_voxel: float = 0.02
    """[m] first voxel edge of that downsampling (grown until the cloud fits); 0 = keep evenly spaced points"""
    stale_after_s: float = 1.0
    """[s] without any cloud for this long, the status says stale"""
    status_rate_hz: float = 2.0
    """status publishing rate [Hz]"""
    origin_max_age_s: float = 1.0
    """[s] a camera's pose stamped further than this from its cloud's stamp is not used with it; 0 = any age"""
    cloud_topics: tuple[str, ...] = ("camera/points",)
    """the cloud topics fused into one scene (one per camera; frames as `frames` accepts); each camera's origin comes
    from the pose topic beside its cloud (`camera/points` -> `camera/pose`); fixed at start-up"""
    cloud_max_age_s: float = 0.5
    """[s] a topic's newest cloud stamped further than this from the newest cloud is left out as stale; 0 = never"""
    frames: FramesConfig = field(default_factory=FramesConfig)

    def __post_init__(self) -> None:
        if not isinstance(self.checkpoint, str):
            raise ConfigError(f"checkpoint: expected a string, got {self.checkpoint!r}")
        check_int("max_points", self.max_points, 1, 10_000_000)
        check_number("downsample_voxel", self.downsample_voxel, 0.0, 0.5)
        check_number("stale_after_s", self.stale_after_s, 0.0, 3600.0, open_low=True)
        check_number("status_rate_hz", self.status_rate_hz, MIN_RATE_HZ, 100.0)
        check_number("origin_max_age_s", self.origin_max_age_s, 0.0, 3600.0)
        check_topics("cloud_topics", self.cloud_topics)
        check_number("cloud_max_age_s", self.cloud_max_age_s, 0.0, 3600.0)


MAX_CLOUD_TOPICS = 8


def check_topics(name: str, topics) -> None:
    """ConfigError unless topics is a list of 1..MAX_CLOUD_TOPICS distinct non-empty topic names."""
    ok = isinstance(topics, tuple | list) and 1 <= len(topics) <= MAX_CLOUD_TOPICS
    ok = ok and all(isinstance(t, str) and t.strip() and " " not in t for t in topics)
    if not ok:
        raise ConfigError(f"{name}: expected 1 to {MAX_CLOUD_TOPICS} topic names, got {topics!r}")
    if len(set(topics)) != len(topics):
        raise ConfigError(f"{name}: {list(topics)} lists a topic twice")


RANGES = {
    SceneEncoderNodeConfig: {
        "max_points": "[1, 10000000]",
        "downsample_voxel": "[0, 0.5]",
        "stale_after_s": "(0, 3600]",
        "status_rate_hz": "[0.01, 100]",
        "origin_max_age_s": "[0, 3600]",
        "cloud_max_age_s": "[0, 3600]",
    }
}
"""Valid ranges of the scene_encoder's parameters, as the validation enforces them."""

READ_ONLY = ("cloud_topics", *FRAMES_READ_ONLY)
"""Parameters fixed at start-up (subscriptions and frames)."""

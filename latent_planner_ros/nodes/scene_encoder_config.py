"""Parameters of the scene_encoder node: one dataclass, mapped 1:1 onto ROS parameters (config/scene_encoder.yaml)."""

from __future__ import annotations

from dataclasses import dataclass

from sim_bridge.params import ConfigError, check_int, check_number


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
    """[s] a camera/pose stamped further than this from a cloud's stamp is not used with it; 0 = any age"""

    def __post_init__(self) -> None:
        if not isinstance(self.checkpoint, str):
            raise ConfigError(f"checkpoint: expected a string, got {self.checkpoint!r}")
        check_int("max_points", self.max_points, 1, 10_000_000)
        check_number("downsample_voxel", self.downsample_voxel, 0.0, 0.5)
        check_number("stale_after_s", self.stale_after_s, 0.0, 3600.0, open_low=True)
        check_number("status_rate_hz", self.status_rate_hz, 0.0, 100.0, open_low=True)
        check_number("origin_max_age_s", self.origin_max_age_s, 0.0, 3600.0)

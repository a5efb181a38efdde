"""Architecture of the collision predictor (scene encoder + per-link classifier)."""

from __future__ import annotations

from dataclasses import asdict, dataclass, field
from typing import Any

from latent_planner_ros.models.scene_encoder import SceneEncoderConfig

COMBINE = ("max", "logsumexp")


@dataclass(frozen=True)
class CollisionNetConfig:
    """Scene encoder and classifier sizes.

    Per link, the classifier sees the voxel features sampled trilinearly at `points_per_link` points along
    the link, those points' positions (normalised to the workspace bounds), the link's 6D rotation, the VAE
    latent z (unless `latent` is 0) and a one-hot of the link; a shared MLP gives one logit per link and the
    links' logits are combined into one (max, or a smooth maximum).
    """

    encoder: SceneEncoderConfig = field(default_factory=SceneEncoderConfig)
    points_per_link: int = 3
    """points along each link where voxel features are sampled"""
    hidden: tuple[int, ...] = (256, 128)
    """hidden widths of the per-link MLP"""
    latent: int = 7
    """dimension of the VAE latent z; 0: the classifier does not read z (a distilled student that sees the link
    poses only, so that checking a configuration needs no VAE encoder pass)"""
    combine: str = "max"
    """how link logits become the global logit: "max" or "logsumexp" """

    def __post_init__(self) -> None:
        if self.combine not in COMBINE:
            raise ValueError(f"combine must be one of {COMBINE}, got {self.combine!r}")
        if self.points_per_link < 1 or self.latent < 0 or not self.hidden:
            raise ValueError("points_per_link must be positive, latent not negative and hidden non-empty")

    def to_dict(self) -> dict:
        return asdict(self)

    @classmethod
    def from_dict(cls, d: dict) -> CollisionNetConfig:
        d = dict(d)
        enc = SceneEncoderConfig.from_dict(d.pop("encoder"))
        fields: dict[str, Any] = {k: tuple(v) if isinstance(v, list) else v for k, v in d.items()}
        return cls(encoder=enc, **fields)

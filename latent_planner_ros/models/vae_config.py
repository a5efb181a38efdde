"""Architecture of the robot-state VAE."""

from __future__ import annotations

from dataclasses import asdict, dataclass

DECODERS = ("plain", "kinematic")


@dataclass(frozen=True)
class VaeConfig:
    """Encoder/decoder MLP sizes and the decoder variant.

    decoder:
        "plain": the decoder outputs the whole standardised state x (the seed);
        "kinematic": the decoder outputs q only, squashed into the joint limits by tanh, and the pose part
        of x is the torch FK of that q (consistent and within limits by construction).
    """

    decoder: str = "kinematic"
    hidden: int = 512
    """units per hidden layer"""
    layers: int = 3
    """hidden layers in the encoder and in the decoder"""
    latent: int = 7
    """latent dimension"""

    def __post_init__(self) -> None:
        if self.decoder not in DECODERS:
            raise ValueError(f"decoder must be one of {DECODERS}, got {self.decoder!r}")
        if self.hidden < 1 or self.layers < 1 or self.latent < 1:
            raise ValueError("hidden, layers and latent must be positive")

    def to_dict(self) -> dict:
        return asdict(self)

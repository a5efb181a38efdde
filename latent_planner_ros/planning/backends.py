"""Build a collision backend by name."""

from __future__ import annotations

from latent_planner_ros.planning.collision_backend import CollisionBackend, NoCollision
from latent_planner_ros.planning.geometric_backend import GeometricBackend


def make_backend(name: str, collision_checkpoint: str = "", cylinder_checkpoint: str = "") -> CollisionBackend:
    """ "learned" (scene embeddings + collision predictor), "geometric" (spheres vs cloud), "cylinders" (LSPP's
    obstacle classifier on state-based cylinders, exact hard check) or "none".

    Raises CheckpointError (learned, missing or bad checkpoint) or ValueError (unknown name).
    """
    if name == "geometric":
        return GeometricBackend()
    if name == "none":
        return NoCollision()
    if name == "learned":
        from latent_planner_ros.planning.learned_backend import LearnedBackend

        return LearnedBackend.load(collision_checkpoint or None)
    if name == "cylinders":
        from latent_planner_ros.planning.cylinder_backend import CylinderBackend

        return CylinderBackend.load(cylinder_checkpoint or None)
    raise ValueError(f"unknown collision backend {name!r}")

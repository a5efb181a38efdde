"""Build a collision backend by name."""

from __future__ import annotations

from latent_planner_ros.planning.collision_backend import CollisionBackend, NoCollision
from latent_planner_ros.planning.geometric_backend import GeometricBackend

CLOUD_SCENE_BACKENDS = ("geometric", "local")
"""backends whose scene is the raw cloud itself (set_scene(cloud)); the learned one takes an embedding"""


def make_backend(name: str, collision_checkpoint: str = "", cylinder_checkpoint: str = "") -> CollisionBackend:
    """ "learned" (scene embeddings + collision predictor), "geometric" (spheres vs cloud), "local" (the local
    collision predictor: the points next to each link), "cylinders" (LSPP's obstacle classifier on state-based
    cylinders, exact hard check) or "none".

    Raises CheckpointError (learned or local, missing or bad checkpoint) or ValueError (unknown name).
    """
    if name == "geometric":
        return GeometricBackend()
    if name == "none":
        return NoCollision()
    if name == "learned":
        from latent_planner_ros.planning.learned_backend import LearnedBackend

        return LearnedBackend.load(collision_checkpoint or None)
    if name == "local":
        from latent_planner_ros.planning.local_backend import LocalBackend

        return LocalBackend.load()
    if name == "cylinders":
        from latent_planner_ros.planning.cylinder_backend import CylinderBackend

        return CylinderBackend.load(cylinder_checkpoint or None)
    raise ValueError(f"unknown collision backend {name!r}")

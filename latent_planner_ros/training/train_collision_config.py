"""Hyperparameters of collision-predictor training (`python -m latent_planner_ros train collision`)."""

from __future__ import annotations

from dataclasses import asdict, dataclass


@dataclass
class TrainCollisionConfig:
    """Training of the collision network on cached labelled scenes, clouds rendered on the fly."""

    family: str = "train"
    """scene family of generated training shards (data/scene_families.py: "train" tabletop, "mix" = tabletop and
    workcells, ...); shards of different families may share a data directory only if generated with distinct
    --data-seed values"""
    val_seen_family: str = "train"
    """family of the validation scenes that select the best network"""
    val_unseen_family: str = "heldout"
    """family of the held-out validation scenes (reported, never used for selection)"""
    data: str = "data_cache/collision/train"
    """directory of training shards (rescanned every `refresh_every` steps, so generation may continue)"""
    val_dir: str = "data_cache/collision"
    """directory holding (or receiving, on first use) the validation shards val_seen/ and val_unseen/"""
    val_scenes: int = 50
    """validation scenes per family (own seed split); model selection uses the training family's only"""
    scenes_per_step: int = 8
    """scenes (clouds) per training step"""
    queries_per_scene: int = 128
    """labelled configurations per scene and step"""
    near_fraction: float = 0.5
    """fraction of a scene's queries drawn from its near-object configurations"""
    hard_fraction: float = 0.25
    """fraction of a scene's queries replaced by the hardest of a larger forward-only candidate set (0 = off)"""
    hard_candidates: int = 4
    """candidate set size for hard mining, in multiples of the replaced queries"""
    lr: float = 1e-3
    """Adam learning rate at the start (cosine decay to lr_final)"""
    lr_final: float = 5e-5
    weight_decay: float = 1e-5
    link_loss_weight: float = 1.0
    """weight of the per-link BCE relative to the global BCE"""
    point_keep: tuple[float, float] = (0.3, 1.0)
    """range of the random fraction of cloud points kept (density augmentation, when not voxel-downsampled)"""
    voxel_downsample_prob: float = 0.5
    """probability that a training cloud is voxel-downsampled (as the sim does) instead of thinned at random"""
    voxel_downsample_size: tuple[float, float] = (0.01, 0.025)
    """range of the downsampling voxel edge [m]"""
    fovy_deg: tuple[float, float] = (40.0, 60.0)
    """range of the training camera's vertical field of view [deg] (intrinsics augmentation)"""
    image_scale: tuple[float, float] = (0.8, 1.4)
    """range of the training camera's image size relative to 192 x 144 pixels"""
    unknown_eye_prob: float = 0.1
    """probability that a training cloud's camera origin is withheld (a network with visibility channels then
    still works, less well, for clouds whose origin is unknown)"""
    views: tuple[float, float] = (1, 1)
    """inclusive range of the number of camera views fused into one training cloud (each point keeps the origin
    of its own camera, as the nodes fuse several cameras)"""
    aim_at_objects: float = 0.0
    """probability that a view looks at one of the scene's obstacles instead of the workspace centre (workcells
    stand all around the base)"""
    threshold: float = 0.2
    """decision threshold on p(collision) for the reported precision/recall (the planner's hard check:
    planning/learned_backend.py CHECK_THRESHOLD)"""
    eval_every: int = 300
    """steps between evaluations and checkpoints"""
    refresh_every: int = 200
    """steps between rescans of the data directory for new shards"""
    seed: int = 0
    threads: int = 2

    def to_dict(self) -> dict:
        return asdict(self)

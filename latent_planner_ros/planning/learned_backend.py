"""Learned collision backend: scene embeddings + the collision predictor (seed chapter 7, III-D).

The differentiable cost is the predictor's p(collision | scene, z). The hard check of interpolated steps
takes the predictor's decision and, when the raw cloud is known (`set_cloud`), also the geometric
sphere-vs-cloud check, so that no accepted segment passes through an observed point (beyond the seed).
"""

from __future__ import annotations

from contextlib import contextmanager
from pathlib import Path

import numpy as np
import torch

from latent_planner_ros.data.link_geometry import LABEL_LINKS
from latent_planner_ros.models import trilinear
from latent_planner_ros.models.collision_io import PLANNER_COLLISION, shipped_collision_path
from latent_planner_ros.models.collision_predictor import CollisionPredictor
from latent_planner_ros.models.scene_encoder import SceneEmbedding
from latent_planner_ros.perception.scene_input import inside_bounds
from latent_planner_ros.planning.ball_query import finite_rows
from latent_planner_ros.planning.collision_backend import BackendDefaults
from latent_planner_ros.planning.geometric_backend import GeometricBackend
from latent_planner_ros.planning.network_domain import share_outside
from latent_planner_ros.robot.panda import LINK_FRAMES
from latent_planner_ros.robot.torch_fk import TorchFK

MAX_VIEWS = 1
"""default `max_views`: the shipped network learned clouds of one camera (and its visibility channels their
shadows); clouds fused from several cameras were the workcells', where it planned slower than the geometric
backend (docs/benchmark.md, "The network's domain: one camera")"""
DOMAIN_SHARE = 0.2
"""default `domain_share`: on the shipped sets' clouds, no tabletop scene has more than 0.18 of its occupied
voxels outside the shipped network's box, and 48 of the first 60 workcell scenes have more than 0.2"""
CHECK_THRESHOLD = 0.2
"""p(collision) at or above which the hard check refuses a configuration: about the lowest threshold that keeps
the shipped network's precision on near-object queries of the held-out family's validation scenes at 0.88 or more,
equal to the acceptance threshold gamma_col (how it was chosen: docs/training.md)."""


class LearnedBackend(BackendDefaults):
    """Collision backend over a CollisionPredictor.

    Args:
        predictor: the collision network and the VAE it reads.
        threshold: p(collision) at or above which `check` calls a configuration colliding.
        geometric_check: also refuse configurations whose spheres contain an observed point (needs a cloud).
        domain_share: a scene with more than this share of its occupied voxels outside the network's box
            (planning/network_domain.py: a workcell, not the tabletop it learned) is planned with the geometric
            backend instead, and `mode` says so; 1.0 = the network always.
        max_views: a cloud fused from more cameras than this is planned with the geometric backend too (the
            network learned what one camera sees); 0 = any number.
    """

    name = "learned"
    mode = "learned"
    """"learned", or "geometric" while the scene lies beyond the network's box (see domain_share)"""

    def __init__(
        self,
        predictor: CollisionPredictor,
        threshold: float = CHECK_THRESHOLD,
        geometric_check: bool = True,
        domain_share: float = DOMAIN_SHARE,
        max_views: int = MAX_VIEWS,
    ):
        self.predictor = predictor
        self.threshold = float(threshold)
        self.domain_share = float(domain_share)
        self.max_views = int(max_views)
        self.mode = "learned"
        self.geometric = GeometricBackend() if geometric_check else None
        self._fallback: GeometricBackend | None = None  # the geometric backend of scenes beyond the box
        self._fallback_cloud: np.ndarray | None = None  # the cloud it holds
        self._forced = False  # geometric_only: every scene goes to the fallback
        self.embedding: SceneEmbedding = predictor.encode(np.zeros((0, 3), dtype=np.float32))
        self._fk = TorchFK()  # every link frame, for the hard check
        self._label_frames = [LINK_FRAMES.index(name) for name in LABEL_LINKS]  # the network's links among them
        self._table: tuple[SceneEmbedding, torch.Tensor] | None = None  # the embedding's rows (trilinear)

    @classmethod
    def load(cls, stem: str | Path | None = None, **kwargs) -> LearnedBackend:
        """The shipped planning predictor (PLANNER_COLLISION) or `stem`; raises CheckpointError for a missing or
        bad checkpoint."""
        stem = shipped_collision_path(PLANNER_COLLISION) if stem is None else stem
        return cls(CollisionPredictor.load(stem), **kwargs)

    # -- scene ------------------------------------------------------------------------------------
    def set_scene(self, scene: SceneEmbedding | np.ndarray, origin: np.ndarray | None = None) -> None:
        """A scene embedding (from the scene_encoder node), or a raw cloud (N, 3) [m] encoded here, seen from
        the camera origin in `world` if known: (3,) [m] for one camera (a non-finite origin counts as unknown),
        or (N, 3) [m] one per point for a cloud fused from several cameras (NaN rows: unknown). The network
        encodes the points inside its workspace box (as the scene_encoder node crops them); the geometric part
        of the hard check keeps every point.

        Raises:
            ValueError: origin is neither (3,) nor (N, 3).
        """
        if isinstance(scene, SceneEmbedding):
            self.embedding = scene
            return
        cloud = np.asarray(scene, dtype=np.float32).reshape(-1, 3)
        keep = finite_rows(cloud)
        if origin is not None:
            origin = np.asarray(origin, dtype=float)
            if origin.size == 3 and origin.shape != (len(cloud), 3):
                origin = origin.reshape(3) if np.all(np.isfinite(origin)) else None
            elif origin.shape == (len(cloud), 3):
                origin = origin[keep]
            else:
                raise ValueError(f"origin: expected shape (3,) or ({len(cloud)}, 3), got {origin.shape}")
        cloud = cloud[keep]
        if self._beyond_box(cloud, count_views(origin)):
            return
        enc = self.predictor.net.config.encoder  # the network sees its workspace box, as in training
        inside = inside_bounds(cloud, enc.bounds_min, enc.bounds_max)
        if origin is not None and origin.ndim == 2:
            origin = origin[inside]
        self.embedding = self.predictor.encode(cloud[inside], origin)
        if self.geometric is not None:  # set_cloud without counting the share outside the box again
            self.geometric.set_check_cloud(cloud)

    def set_cloud(self, cloud: np.ndarray, views: int = 1) -> None:
        """The raw cloud (N, 3) [m] for the geometric part of the hard check, fused from `views` cameras (and the
        choice of `mode`: with an embedding from the scene_encoder node, this is where the planner sees how far
        the scene reaches and from how many cameras)."""
        if self._beyond_box(cloud, views):
            return
        if self.geometric is not None:
            self.geometric.set_check_cloud(cloud)

    @contextmanager
    def geometric_only(self):
        """Within the block, every scene is planned with the geometric backend (`mode` "geometric"): a scene set
        then, or (an embedding) the raw cloud of the hard check; afterwards the backend is as before."""
        saved = (self._forced, self.mode, self._fallback_cloud)
        self._forced = True
        if self.geometric is not None:
            self._use_fallback(self.geometric.cloud)
        try:
            yield self
        finally:
            self._forced, self.mode = saved[0], saved[1]
            if saved[1] == "geometric" and saved[2] is not None:
                self._use_fallback(saved[2])

    def _stand_in(self) -> GeometricBackend:
        """The geometric backend of scenes beyond the network's box (exists whenever `mode` is "geometric")."""
        assert self._fallback is not None, "mode is geometric only once the fallback holds a scene"
        return self._fallback

    def _use_fallback(self, cloud: np.ndarray) -> None:
        self.mode = "geometric"
        self._fallback = self._fallback or GeometricBackend()
        self._fallback.set_scene(cloud)
        self._fallback_cloud = cloud

    def _beyond_box(self, cloud: np.ndarray, views: int = 1) -> bool:
        """Set `mode` for cloud (N, 3) [m] seen by `views` cameras; in geometric mode, give the cloud to the
        geometric backend."""
        enc = self.predictor.net.config.encoder
        if self._forced:
            self._use_fallback(cloud)
            return True
        self.mode = "learned"
        in_views = self.max_views <= 0 or views <= self.max_views
        if in_views and (
            self.domain_share >= 1.0 or share_outside(cloud, enc.bounds_min, enc.bounds_max) <= self.domain_share
        ):  # the share is counted only for the views the network learned
            return False
        self.mode = "geometric"
        self._fallback = self._fallback or GeometricBackend()
        self._fallback.set_scene(cloud)
        return True

    def embedding_from_points(self, centres: np.ndarray, features: np.ndarray) -> SceneEmbedding:
        """The SceneEmbedding of a `scene_embedding` message's voxel centres (V, 3) [m] and features (V, C)
        float32 (msg_adapters.cloud_to_embedding decodes the message); ValueError for a grid or width that is not
        this network's."""
        return self.predictor.embedding_from_points(centres, features)

    # -- queries ----------------------------------------------------------------------------------
    takes_frames = True  # p_collision accepts the link frames of q (AmpLs shares its FK with the network)

    def p_collision(self, q: torch.Tensor, z: torch.Tensor, frames: torch.Tensor | None = None) -> torch.Tensor:
        """p(collision) (B,) of decoded configurations q (B, 7) with their latents z (B, L); differentiable.
        frames: the poses (B, len(LINK_FRAMES), 4, 4) [m] of q's link frames if already computed (TorchFK)."""
        if self.mode == "geometric":
            return self._stand_in().p_collision(q, z, frames).to(z.dtype)
        poses = None if frames is None else frames[:, self._label_frames].float()
        logits = self.predictor.link_logits_q(self.embedding, q.float(), z.float(), poses)
        return torch.sigmoid(self.predictor.net.combine(logits)).to(z.dtype)

    def link_p_collision(self, q: np.ndarray) -> dict[str, float]:
        """p(collision) of each of the network's links for one configuration q (7,) [rad]: {link frame name: p}
        (the geometric fallback's links while it stands in)."""
        if self.mode == "geometric":
            return self._stand_in().link_p_collision(q)
        with torch.no_grad():
            q_t = torch.as_tensor(np.asarray(q, dtype=np.float32)[None])
            p = torch.sigmoid(self.predictor.link_logits_q(self.embedding, q_t, None))[0].numpy()
        return {LINK_FRAMES[f]: float(v) for f, v in zip(self._label_frames, p, strict=True)}

    def check(self, q: np.ndarray) -> np.ndarray:
        """Hard decision (M,) bool for configurations q (M, 7) [rad]."""
        q = np.atleast_2d(np.asarray(q, dtype=np.float64))
        frames = self._fk.frames_np(q)  # (M, F, 4, 4): one FK for both parts of the check
        if self.mode == "geometric":
            return self._stand_in().check_frames(frames)
        # the cheaper geometric check first: the network only sees the configurations it left open
        hits = self.geometric.check_frames(frames) if self.geometric is not None else np.zeros(len(q), dtype=bool)
        todo = np.flatnonzero(~hits)
        if not len(todo):
            return hits
        net = self.predictor.net
        if net.reads_latent:  # the latent comes from a VAE encoder pass of q
            with torch.no_grad():
                p = self.predictor.p_collision_q(self.embedding, torch.from_numpy(q[todo]).float()).numpy()
        else:
            if self._table is None or self._table[0] is not self.embedding:
                self._table = (self.embedding, trilinear.channels_last(self.embedding.features))
            logits = net.check_logits(self._table[1], frames[todo][:, self._label_frames])
            p = torch.sigmoid(net.combine(logits)).numpy()
        hits[todo] = p >= self.threshold
        return hits


def count_views(origin: np.ndarray | None) -> int:
    """How many cameras a cloud was fused from: the distinct finite rows of its per-point origins (N, 3) [m]
    (views come one after the other, so the rows that start a run are enough); 1 for one origin (3,) or None."""
    if origin is None or origin.ndim != 2 or len(origin) == 0:
        return 1
    rows = origin[np.isfinite(origin).all(axis=1)]
    if len(rows) == 0:
        return 1
    starts = np.ones(len(rows), dtype=bool)
    starts[1:] = (rows[1:] != rows[:-1]).any(axis=1)
    return max(1, len(np.unique(rows[starts], axis=0)))

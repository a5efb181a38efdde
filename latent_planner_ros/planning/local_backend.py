"""Local learned collision backend: each link's p(collision) from the cloud points next to it (models/local_predictor).

The cost is the local network's p(collision | the points near each link, q), differentiable through the link
poses of AmpLs's forward kinematics. The hard check is the geometric one (an observed point inside an arm
sphere, exact against the link hulls) and, for the configurations it passes, the network's decision at
`threshold`, as the grid network's backend does it (planning/learned_backend.py). No box: the network sees the
whole cloud the planner is given, all around the base.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import torch

from latent_planner_ros.data.link_geometry import LABEL_LINKS
from latent_planner_ros.models.local_predictor import LocalPredictor
from latent_planner_ros.planning.ball_query import BallQuery, finite_rows
from latent_planner_ros.planning.collision_backend import BackendDefaults
from latent_planner_ros.planning.geometric_backend import GeometricBackend
from latent_planner_ros.robot.panda import LINK_FRAMES
from latent_planner_ros.robot.torch_fk import TorchFK

LOCAL_CHECK_THRESHOLD = 0.2
"""p(collision) at or above which the hard check refuses a configuration the geometric check passed: gamma_col,
as for the grid network; on the training family's validation scenes (near-object queries) the shipped local
network has precision 0.95 and recall 0.96 there (docs/training.md)"""


class LocalBackend(BackendDefaults):
    """Collision backend over a LocalPredictor.

    Args:
        predictor: the local network.
        threshold: p(collision) at or above which `check` calls a configuration colliding.
    """

    name = "local"
    takes_frames = True  # p_collision reads AmpLs's link frames (one FK per step)

    def __init__(self, predictor: LocalPredictor, threshold: float = LOCAL_CHECK_THRESHOLD):
        self.predictor = predictor
        self.threshold = float(threshold)
        self.geometric = GeometricBackend()
        self.scene = predictor.encode(np.zeros((0, 3), dtype=np.float32))
        self._fk = TorchFK()
        self._label_frames = [LINK_FRAMES.index(name) for name in LABEL_LINKS]

    @classmethod
    def load(cls, stem: str | Path | None = None, **kwargs) -> LocalBackend:
        """The shipped local predictor or `stem`; raises CheckpointError for a missing or bad checkpoint."""
        return cls(LocalPredictor.load(stem), **kwargs)

    def set_scene(self, scene: np.ndarray, origin: np.ndarray | None = None) -> None:
        """A cloud (N, 3) [m] in `world`, seen from origin: (3,) [m] one camera (non-finite: unknown), (N, 3) one
        per point (NaN rows: unknown), or None.

        Raises:
            ValueError: origin is neither (3,) nor (N, 3).
        """
        cloud = np.asarray(scene, dtype=np.float32).reshape(-1, 3)
        keep = finite_rows(cloud)
        eyes = None
        if origin is not None:
            o = np.asarray(origin, dtype=np.float32)
            if o.shape == cloud.shape:
                eyes = o[keep]
            elif o.size == 3:
                eyes = o.reshape(3) if np.all(np.isfinite(o)) else None
            else:
                raise ValueError(f"origin: expected shape (3,) or ({len(cloud)}, 3), got {o.shape}")
        cloud = cloud[keep]
        self.scene = self.predictor.encode(cloud, eyes)
        if len(cloud):  # the occupancy prefilter spares the KD-tree the anchors with no point near (same answers)
            balls = BallQuery(cloud)
            self.scene.near = lambda centres, radius: balls.occupied(centres, np.asarray(radius))
        self.geometric.set_check_cloud(cloud)

    def p_collision(self, q: torch.Tensor, z: torch.Tensor, frames: torch.Tensor | None = None) -> torch.Tensor:
        """p(collision) (B,) of q (B, 7) [rad] (z: not read); frames (B, len(LINK_FRAMES), 4, 4) [m]: q's link
        frames if already computed, differentiable in q."""
        frames = self._fk(q.float()) if frames is None else frames
        logits = self.predictor.link_logits_frames(self.scene, frames[:, self._label_frames].float())
        return torch.sigmoid(self.predictor.combine(logits)).to(q.dtype)

    def link_p_collision(self, q: np.ndarray) -> dict[str, float]:
        """{link frame name: p(collision)} of one configuration q (7,) [rad]."""
        with torch.no_grad():
            q_t = torch.as_tensor(np.asarray(q, dtype=np.float32)[None])
            p = torch.sigmoid(self.predictor.link_logits_q(self.scene, q_t))[0].numpy()
        return {name: float(v) for name, v in zip(LABEL_LINKS, p, strict=True)}

    def check(self, q: np.ndarray) -> np.ndarray:
        """Hard decision (M,) bool for configurations q (M, 7) [rad]: the geometric check, then the network."""
        q = np.atleast_2d(np.asarray(q, dtype=np.float64))
        frames = self._fk.frames_np(q)
        hits = self.geometric.check_frames(frames)
        todo = np.flatnonzero(~hits)
        if not len(todo) or self.scene.tree is None:
            return hits
        with torch.no_grad():
            sel = torch.as_tensor(frames[todo][:, self._label_frames], dtype=torch.float32)
            p = torch.sigmoid(self.predictor.combine(self.predictor.link_logits_frames(self.scene, sel))).numpy()
        hits[todo] = p >= self.threshold
        return hits

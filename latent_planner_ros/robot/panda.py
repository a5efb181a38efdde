"""The Panda as a pinocchio model: arm joints 1-7 free, fingers locked fully open.

This is the kinematic reference of the project: the torch FK and the samplers are tested against it.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np
import pinocchio as pin

from latent_planner_ros.robot.description import panda_description
from latent_planner_ros.robot.limits import FINGER_OPEN, JOINT_NAMES

EE_FRAME = "panda_hand_tcp"
"""Default end-effector frame."""

LINK_FRAMES: tuple[str, ...] = (
    "panda_link0",
    "panda_link1",
    "panda_link2",
    "panda_link3",
    "panda_link4",
    "panda_link5",
    "panda_link6",
    "panda_link7",
    "panda_link8",
    "panda_hand",
    "panda_leftfinger",
    "panda_rightfinger",
    "panda_hand_tcp",
)
"""Body frames the torch FK computes (every link with a collision geometry, plus flange and TCP)."""


@dataclass(frozen=True)
class PandaModel:
    """A pinocchio model of the arm (nq = 7) with its collision geometry.

    Attributes:
        model: pinocchio.Model with the finger joints locked open.
        collision_model: pinocchio.GeometryModel with the collision geometry (STL meshes, finger primitives).
    """

    model: pin.Model
    collision_model: pin.GeometryModel

    def frame_id(self, name: str) -> int:
        """Index of a frame; raises KeyError naming the frame if it does not exist."""
        if not self.model.existFrame(name):
            raise KeyError(f"frame {name!r} is not in the Panda model")
        return self.model.getFrameId(name)

    def fk(self, q: np.ndarray, frame: str = EE_FRAME) -> pin.SE3:
        """Pose of `frame` in `world` (= panda_link0) for one configuration q (shape (7,), rad)."""
        data = self.model.createData()
        pin.framesForwardKinematics(self.model, data, np.asarray(q, dtype=float))
        return data.oMf[self.frame_id(frame)].copy()

    def fk_batch(self, q: np.ndarray, frame: str = EE_FRAME) -> tuple[np.ndarray, np.ndarray]:
        """Positions (N, 3) [m] and rotation matrices (N, 3, 3) of `frame` for q of shape (N, 7)."""
        q = np.atleast_2d(np.asarray(q, dtype=float))
        fid = self.frame_id(frame)
        data = self.model.createData()
        pos = np.empty((len(q), 3))
        rot = np.empty((len(q), 3, 3))
        for i, qi in enumerate(q):
            pin.framesForwardKinematics(self.model, data, qi)
            pos[i] = data.oMf[fid].translation
            rot[i] = data.oMf[fid].rotation
        return pos, rot


@lru_cache(maxsize=1)
def load_panda() -> PandaModel:
    """Build (once per process) the arm model from the example-robot-data URDF and SRDF."""
    desc = panda_description()
    full, collision, _visual = pin.buildModelsFromUrdf(
        str(desc.urdf),
        package_dirs=[str(desc.package_root)],
        geometry_types=[pin.GeometryType.COLLISION, pin.GeometryType.VISUAL],
    )
    q_full = pin.neutral(full)
    locked = []
    for name in ("panda_finger_joint1", "panda_finger_joint2"):
        jid = full.getJointId(name)
        q_full[full.joints[jid].idx_q] = FINGER_OPEN
        locked.append(jid)
    model, collision_model = pin.buildReducedModel(full, collision, locked, q_full)
    names = tuple(model.names[1:])
    if names != JOINT_NAMES:
        raise RuntimeError(f"unexpected Panda joints {names}, expected {JOINT_NAMES}")
    return PandaModel(model=model, collision_model=collision_model)

"""Batched, differentiable forward kinematics of the Panda arm in torch.

Built from the pinocchio model (joint placements and frame placements), so it cannot drift from the
reference; tested against pinocchio to 1e-5 m / 1e-5 rad. Small CPU batches (planning) run the same chain in
float64 numpy, large ones (training) in torch; both have the closed-form first derivative (no double backward).
"""

from __future__ import annotations

from typing import Any

import numpy as np
import torch

from latent_planner_ros.robot.panda import EE_FRAME, LINK_FRAMES, load_panda

NUMPY_MAX_BATCH = 1024
"""CPU batches up to this size run in float64 numpy (planning: a few times faster than torch, whose every op
costs microseconds of dispatch); larger ones (training) in torch"""


def _use_numpy(q: torch.Tensor) -> bool:
    return q.device.type == "cpu" and q.shape[0] <= NUMPY_MAX_BATCH


class TorchFK(torch.nn.Module):
    """Forward kinematics for a batch of configurations.

    Every arm joint of the Panda is a revolute joint about its local z axis, so joint i's pose is
    ``T_parent @ M_i @ Rz(q_i)`` with the fixed placement M_i taken from pinocchio.

    Args:
        frames: names of the frames to return (default: every link frame and the TCP).
        dtype: computation dtype (float32 for training and planning, float64 for checks).
    """

    # buffers (register_buffer in __init__)
    rz_cos: torch.Tensor
    rz_sin: torch.Tensor
    rz_const: torch.Tensor

    def __init__(self, frames: tuple[str, ...] = LINK_FRAMES, dtype: torch.dtype = torch.float32):
        super().__init__()
        panda = load_panda()
        model = panda.model
        self.frames = tuple(frames)
        placements = np.stack([model.jointPlacements[j].homogeneous for j in range(1, model.njoints)])
        parents = [int(model.parents[j]) for j in range(1, model.njoints)]
        if parents != list(range(7)):
            raise RuntimeError(f"expected a serial chain, got parents {parents}")
        frame_joint, frame_place = [], []
        for name in self.frames:
            frame = model.frames[panda.frame_id(name)]
            frame_joint.append(int(frame.parentJoint))
            frame_place.append(frame.placement.homogeneous)
        # M_j @ Rz(q) = cos(q) A_j + sin(q) B_j + C_j: Rz mixes only the first two columns of the placement M_j
        m = torch.as_tensor(placements, dtype=dtype)  # (7, 4, 4)
        zero = torch.zeros_like(m[..., 0])
        self.register_buffer("rz_cos", torch.stack([m[..., 0], m[..., 1], zero, zero], -1), persistent=False)
        self.register_buffer("rz_sin", torch.stack([m[..., 1], -m[..., 0], zero, zero], -1), persistent=False)
        self.register_buffer("rz_const", torch.stack([zero, zero, m[..., 2], m[..., 3]], -1), persistent=False)
        # frames placed off their joint, per joint: (joint, frame indices, buffer of their placements (4, 4k))
        self.placed_groups: list[tuple[int, list[int], str]] = []
        placed = [i for i, p in enumerate(frame_place) if not np.allclose(p, np.eye(4), rtol=0, atol=1e-12)]
        for j in sorted({frame_joint[i] for i in placed}):
            idx = [i for i in placed if frame_joint[i] == j]
            cat = np.concatenate([frame_place[i] for i in idx], 1)
            self.register_buffer(f"placed_{j}", torch.as_tensor(cat, dtype=dtype), persistent=False)
            self.placed_groups.append((j, idx, f"placed_{j}"))
        self.frame_joint = frame_joint  # joint index 0..7 (0 = world) each frame hangs from
        # the same chain in float64 numpy for small CPU batches (NUMPY_MAX_BATCH)
        self._np: dict[str, Any] = {
            "cos": self.rz_cos.double().numpy(),
            "sin": self.rz_sin.double().numpy(),
            "const": self.rz_const.double().numpy(),
            "groups": [(j, idx, getattr(self, buffer).double().numpy()) for j, idx, buffer in self.placed_groups],
            # after[j, f]: frame f moves with joint j
            "after": (np.array(frame_joint)[None, :] > np.arange(7)[:, None]).astype(np.float64),
            "frame_joint": np.array(frame_joint),
            "eye": np.eye(4),
        }
        self.ee_index = self.frames.index(EE_FRAME) if EE_FRAME in self.frames else None

    def forward(self, q: torch.Tensor) -> torch.Tensor:
        """Homogeneous transforms of the frames.

        Args:
            q: joint positions, shape (..., 7) [rad].
        Returns:
            shape (..., F, 4, 4): pose of each frame in `world`, F = len(self.frames). Differentiable w.r.t. q
            (first derivatives, computed in closed form: see _Kinematics).
        """
        batch = q.shape[:-1]
        q = q.reshape(-1, 7)
        if q.requires_grad:
            out = _Kinematics.apply(q.to(self.rz_cos.dtype), self)
        elif _use_numpy(q):
            out = torch.from_numpy(self._frames_np(q.numpy().astype(np.float64))[0]).to(self.rz_cos.dtype)
        else:
            out = self._frames_torch(q.to(self.rz_cos.dtype))[0]
        return out.reshape(*batch, len(self.frames), 4, 4)

    def _frames_torch(self, q: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """Frame poses (n, F, 4, 4) and joint poses (n, 8, 4, 4) (index 0 = world) for q (n, 7) [rad], in torch
        (large batches, other devices)."""
        n = q.shape[0]
        c, s = torch.cos(q)[..., None, None], torch.sin(q)[..., None, None]
        local = c * self.rz_cos + s * self.rz_sin + self.rz_const  # (n, 7, 4, 4)
        world = [torch.eye(4, dtype=q.dtype, device=q.device).expand(n, 4, 4)]
        for j in range(7):
            world.append(local[:, 0] if j == 0 else torch.bmm(world[-1], local[:, j]))
        joints = torch.stack(world, 1)  # (n, 8, 4, 4); index 0 = world
        frames = joints[:, self.frame_joint]  # frames whose placement is the identity are their joint's pose
        for j, idx, buffer in self.placed_groups:  # the others: one (n*4, 4) @ (4, 4k) product per joint
            placed = (joints[:, j] @ getattr(self, buffer)).reshape(n, 4, len(idx), 4)
            frames[:, idx] = placed.transpose(1, 2)
        return frames, joints

    def _frames_np(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """`_frames_torch` in float64 numpy: q (n, 7) [rad] -> frames (n, F, 4, 4), joints (n, 8, 4, 4)."""
        n, b = len(q), self._np
        local = np.cos(q)[..., None, None] * b["cos"] + np.sin(q)[..., None, None] * b["sin"] + b["const"]
        joints = np.empty((n, 8, 4, 4))
        joints[:, 0] = b["eye"]
        joints[:, 1] = local[:, 0]
        for j in range(1, 7):
            np.matmul(joints[:, j], local[:, j], out=joints[:, j + 1])
        frames = joints[:, b["frame_joint"]]
        for j, idx, placement in b["groups"]:
            frames[:, idx] = (joints[:, j] @ placement).reshape(n, 4, len(idx), 4).transpose(0, 2, 1, 3)
        return frames, joints

    def frames_np(self, q: np.ndarray) -> np.ndarray:
        """Frame poses (M, F, 4, 4) float64 [m] of q (M, 7) [rad] in numpy (no torch, no autograd): for checks."""
        return self._frames_np(np.asarray(q, dtype=np.float64).reshape(-1, 7))[0]

    def ee_pose(self, q: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """End-effector (panda_hand_tcp) position (..., 3) [m] and rotation matrix (..., 3, 3)."""
        if self.ee_index is None:
            raise ValueError(f"{EE_FRAME} is not among this FK's frames")
        t = self.forward(q)[..., self.ee_index, :, :]
        return t[..., :3, 3], t[..., :3, :3]


class _Kinematics(torch.autograd.Function):
    """TorchFK with a closed-form backward: one small graph node instead of the ~100 of the matrix chain.

    Joint j turns every frame after it about its world axis a_j through p_j, so dT_f/dq_j = X_j T_f with the
    twist X_j = [[skew(a_j), p_j x a_j], [0, 0]]; the gradient is grad_q_j = sum_f <X_j, G_f T_f^T> over the frames
    f after joint j (G_f the incoming gradient of T_f).
    """

    @staticmethod
    def forward(ctx, q: torch.Tensor, fk: TorchFK) -> torch.Tensor:
        if _use_numpy(q):  # float64 numpy, like TorchFK._frames_np
            frames, joints = fk._frames_np(q.detach().numpy().astype(np.float64))
            ctx.numpy = (frames, joints[:, 1:], fk._np["after"])
            return torch.from_numpy(frames).to(q.dtype)
        frames_t, joints_t = fk._frames_torch(q)
        ctx.numpy = None
        ctx.save_for_backward(
            frames_t, joints_t[:, 1:], torch.as_tensor(fk._np["after"], dtype=q.dtype, device=q.device)
        )
        return frames_t

    @staticmethod
    def backward(ctx, grad: torch.Tensor):
        if ctx.numpy is not None:
            frames, joints, after = ctx.numpy  # (n, F, 4, 4), (n, 7, 4, 4), (7, F)
            g = grad.detach().numpy().astype(np.float64) @ np.swapaxes(frames, -1, -2)  # G_f T_f^T, (n, F, 4, 4)
            m = np.matmul(after, g.reshape(*g.shape[:2], 16)).reshape(-1, 7, 4, 4)  # summed per joint
            cross = np.cross
        else:
            frames, joints, after = ctx.saved_tensors
            m = torch.einsum("jf,nfab,nfcb->njac", after, grad, frames)  # sum_f G_f T_f^T per joint, (n, 7, 4, 4)
            cross = torch.linalg.cross
        a, p = joints[..., :3, 2], joints[..., :3, 3]  # joint axes and origins in world, (n, 7, 3)
        # <skew(a), M[:3, :3]> = a . (M32 - M23, M13 - M31, M21 - M12)
        parts = (m[..., 2, 1] - m[..., 1, 2], m[..., 0, 2] - m[..., 2, 0], m[..., 1, 0] - m[..., 0, 1])
        w = np.stack(parts, -1) if ctx.numpy is not None else torch.stack(parts, -1)
        grad_q = (a * w).sum(-1) + (cross(p, a) * m[..., :3, 3]).sum(-1)
        return torch.as_tensor(grad_q, dtype=grad.dtype), None

"""The batched torch FK matches pinocchio on every frame."""

import numpy as np
import pinocchio as pin
import torch

from latent_planner_ros.robot.limits import Q_MAX, Q_MIN
from latent_planner_ros.robot.panda import EE_FRAME, LINK_FRAMES, load_panda
from latent_planner_ros.robot.torch_fk import TorchFK


def _pinocchio_frames(q: np.ndarray) -> np.ndarray:
    panda = load_panda()
    data = panda.model.createData()
    ids = [panda.frame_id(f) for f in LINK_FRAMES]
    out = np.empty((len(q), len(ids), 4, 4))
    for i, qi in enumerate(q):
        pin.framesForwardKinematics(panda.model, data, qi)
        for k, fid in enumerate(ids):
            out[i, k] = data.oMf[fid].homogeneous
    return out


def rotation_error(rel: np.ndarray) -> np.ndarray:
    """Angle [rad] of near-identity rotations (..., 3, 3) from their skew part (well conditioned near 0)."""
    skew = 0.5 * (rel - np.swapaxes(rel, -1, -2))
    axis = np.stack([skew[..., 2, 1], skew[..., 0, 2], skew[..., 1, 0]], -1)
    return np.arcsin(np.clip(np.linalg.norm(axis, axis=-1), 0, 1))


def test_torch_fk_matches_pinocchio_on_10k_configurations(rng):
    q = rng.uniform(Q_MIN, Q_MAX, size=(10_000, 7))
    ref = _pinocchio_frames(q)
    for dtype, tol in ((torch.float64, 1e-9), (torch.float32, 1e-5)):
        got = TorchFK(dtype=dtype)(torch.as_tensor(q)).double().numpy()
        pos_err = np.abs(got[..., :3, 3] - ref[..., :3, 3]).max()
        rel = np.swapaxes(ref[..., :3, :3], -1, -2) @ got[..., :3, :3]
        rot_err = rotation_error(rel).max()
        assert pos_err < tol, (dtype, pos_err)
        assert rot_err < 1e-5, (dtype, rot_err)


def test_ee_pose_is_the_tcp_and_keeps_batch_shape(rng):
    fk = TorchFK()
    q = torch.as_tensor(rng.uniform(Q_MIN, Q_MAX, size=(2, 3, 7)), dtype=torch.float32)
    pos, rot = fk.ee_pose(q)
    assert pos.shape == (2, 3, 3) and rot.shape == (2, 3, 3, 3)
    ref = load_panda().fk(q[1, 2].double().numpy(), EE_FRAME)
    np.testing.assert_allclose(pos[1, 2].numpy(), ref.translation, atol=1e-5)


def test_fk_is_differentiable():
    fk = TorchFK(dtype=torch.float64)
    q = torch.zeros(1, 7, dtype=torch.float64)
    q[0, 3] = -1.5
    q.requires_grad_(True)
    assert torch.autograd.gradcheck(lambda x: fk.ee_pose(x)[0], (q,))


def test_the_closed_form_gradient_matches_autograd_and_pinocchio(rng):
    """_Kinematics' backward: gradcheck in float64 on every frame, and the TCP position's Jacobian equals
    pinocchio's (LOCAL_WORLD_ALIGNED linear part)."""
    fk = TorchFK(dtype=torch.float64)
    q = torch.as_tensor(rng.uniform(Q_MIN, Q_MAX, size=(4, 7))).requires_grad_(True)
    assert torch.autograd.gradcheck(fk, (q,))
    panda = load_panda()
    data = panda.model.createData()
    tcp = panda.frame_id(EE_FRAME)
    for qi in q.detach().numpy():
        jac = torch.autograd.functional.jacobian(lambda x: fk.ee_pose(x)[0], torch.as_tensor(qi)).numpy()
        pin.computeJointJacobians(panda.model, data, qi)
        pin.framesForwardKinematics(panda.model, data, qi)
        ref = pin.getFrameJacobian(panda.model, data, tcp, pin.LOCAL_WORLD_ALIGNED)[:3, :7]
        assert np.abs(jac - ref).max() < 1e-9


def test_numpy_and_torch_paths_agree_on_frames_and_gradients(rng, monkeypatch):
    """Small CPU batches run in numpy, large ones in torch: the same frames and closed-form gradients."""
    import latent_planner_ros.robot.torch_fk as torch_fk

    fk = TorchFK(dtype=torch.float64)
    q = torch.as_tensor(rng.uniform(Q_MIN, Q_MAX, size=(64, 7)))
    weights = torch.as_tensor(rng.standard_normal((64, len(fk.frames), 4, 4)))
    results = []
    for limit in (torch_fk.NUMPY_MAX_BATCH, 0):  # numpy, then torch
        monkeypatch.setattr(torch_fk, "NUMPY_MAX_BATCH", limit)
        x = q.clone().requires_grad_(True)
        frames = fk(x)
        (frames * weights).sum().backward()
        results.append((frames.detach().numpy(), x.grad.numpy()))
    (f_np, g_np), (f_torch, g_torch) = results
    np.testing.assert_allclose(f_np, f_torch, atol=1e-12)
    np.testing.assert_allclose(g_np, g_torch, atol=1e-9)
    assert np.abs(g_np).max() > 1e-3  # a real gradient was compared

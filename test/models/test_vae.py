"""The robot-state VAE: decoder variants, gradients, checkpoint errors."""

import numpy as np
import pytest
import torch

from latent_planner_ros.models.checkpoint import CheckpointError
from latent_planner_ros.models.vae import RobotStateVAE
from latent_planner_ros.models.vae_config import VaeConfig
from latent_planner_ros.models.vae_io import load_vae, save_vae
from latent_planner_ros.robot.limits import Q_MAX, Q_MIN
from latent_planner_ros.robot.panda import load_panda
from latent_planner_ros.robot.rotations import matrix_to_rot6d_np


def _small(decoder: str) -> RobotStateVAE:
    return RobotStateVAE(VaeConfig(decoder=decoder, hidden=32, layers=2))


def test_kinematic_decoder_pose_equals_pinocchio_fk_and_stays_in_limits():
    model = _small("kinematic")
    z = torch.randn(64, 7) * 5.0  # far out in the latent space too
    with torch.no_grad():
        dec = model.decode(z)
    q = dec.q.double().numpy()
    assert np.all(q >= Q_MIN) and np.all(q <= Q_MAX)
    panda = load_panda()
    for i in range(0, 64, 8):
        m = panda.fk(q[i])
        np.testing.assert_allclose(dec.pos[i].numpy(), m.translation, atol=1e-5)
        np.testing.assert_allclose(dec.rot6d[i].numpy(), matrix_to_rot6d_np(m.rotation), atol=1e-5)


@pytest.mark.parametrize("decoder", ["plain", "kinematic"])
def test_decoder_gradient_matches_finite_differences(decoder):
    model = _small(decoder).double()
    model.fk = model.fk.double()
    z = torch.randn(3, 7, dtype=torch.float64, requires_grad=True)
    assert torch.autograd.gradcheck(lambda v: model.decode(v).x, (z,), eps=1e-6, atol=1e-5)


@pytest.mark.parametrize("decoder", ["plain", "kinematic"])
def test_decode_q_equals_the_q_of_decode(decoder):
    model = _small(decoder)
    model.set_normalisation(torch.randn(16), torch.rand(16) + 0.5)
    z = torch.randn(5, 7)
    torch.testing.assert_close(model.decode_q(z), model.decode(z).q)


def test_log_prior_and_kl():
    z = torch.zeros(2, 7)
    assert torch.allclose(RobotStateVAE.log_prior(z), torch.full((2,), -3.5 * np.log(2 * np.pi)))
    mu, logvar = torch.zeros(1, 7), torch.zeros(1, 7)
    assert float(RobotStateVAE.kl(mu, logvar)) == pytest.approx(0.0)
    assert float(RobotStateVAE.kl(torch.ones(1, 7), logvar)) == pytest.approx(3.5)


def test_save_load_round_trip(tmp_path):
    model = _small("plain")
    model.set_normalisation(torch.arange(16.0), torch.full((16,), 2.0))
    save_vae(tmp_path / "m", model, {"note": "test"})
    loaded, meta = load_vae(tmp_path / "m")
    assert meta["architecture"]["decoder"] == "plain" and meta["note"] == "test"
    z = torch.randn(5, 7)
    torch.testing.assert_close(loaded.decode(z).x, model.eval().decode(z).x)


def test_missing_truncated_and_mismatched_checkpoints_name_the_file(tmp_path):
    with pytest.raises(CheckpointError, match="missing"):
        load_vae(tmp_path / "nothing")
    model = _small("kinematic")
    save_vae(tmp_path / "m", model, {})
    w = tmp_path / "m.safetensors"
    w.write_bytes(w.read_bytes()[: len(w.read_bytes()) // 2])
    with pytest.raises(CheckpointError, match="truncated or corrupt"):
        load_vae(tmp_path / "m")
    save_vae(tmp_path / "m", model, {})
    meta = (tmp_path / "m.json").read_text().replace('"hidden": 32', '"hidden": 64')
    (tmp_path / "m.json").write_text(meta)
    with pytest.raises(CheckpointError, match="does not match"):
        load_vae(tmp_path / "m")

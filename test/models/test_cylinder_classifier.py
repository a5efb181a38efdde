"""LSPP's classifier on (z, o): shapes, gradients, checkpoint round trip and refusal of foreign files."""

import pytest
import torch

from latent_planner_ros.models.checkpoint import CheckpointError, save_checkpoint
from latent_planner_ros.models.cylinder_classifier import (
    CylinderClassifier,
    CylinderClassifierConfig,
    load_classifier,
    save_classifier,
)


def test_every_latent_meets_every_cylinder_and_gradients_reach_z():
    model = CylinderClassifier(CylinderClassifierConfig(hidden=16, layers=2))
    z = torch.randn(5, 7, requires_grad=True)
    p = model.p_each(z, torch.tensor([[0.5, 0.0, 0.4, 0.05], [0.0, 0.5, 0.8, 0.08], [0.3, 0.3, 0.2, 0.1]]))
    assert p.shape == (5, 3) and torch.all((p > 0) & (p < 1))
    p.sum().backward()
    assert z.grad is not None and torch.all(torch.isfinite(z.grad)) and z.grad.abs().sum() > 0
    assert model.p_each(z, torch.zeros(0, 4)).shape == (5, 0)


def test_checkpoint_round_trip_keeps_weights_and_normalisation(tmp_path):
    model = CylinderClassifier(CylinderClassifierConfig(hidden=16, layers=2))
    model.set_normalisation(torch.tensor([0.1, 0.2, 0.5, 0.06]), torch.tensor([0.4, 0.4, 0.25, 0.02]))
    save_classifier(tmp_path / "c", model, {"note": "test"})
    back, meta = load_classifier(tmp_path / "c")
    z, o = torch.randn(4, 7), torch.rand(4, 4)
    assert torch.allclose(back(z, o), model(z, o))
    assert meta["architecture"] == {"latent": 7, "hidden": 16, "layers": 2}
    assert meta["normalisation"]["o_std"] == pytest.approx([0.4, 0.4, 0.25, 0.02])


def test_a_foreign_or_missing_checkpoint_is_refused(tmp_path):
    save_checkpoint(tmp_path / "other", {"w": torch.zeros(1)}, {"kind": "robot_state_vae"})
    with pytest.raises(CheckpointError, match="not an LSPP"):
        load_classifier(tmp_path / "other")
    with pytest.raises(CheckpointError, match="missing"):
        load_classifier(tmp_path / "absent")

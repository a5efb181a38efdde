"""Cylinder backend: the combined probability is the seed's summed obstacle loss; the hard check is exact."""

import numpy as np
import pytest
import torch

from latent_planner_ros.models.cylinder_classifier import CylinderClassifier, CylinderClassifierConfig
from latent_planner_ros.planning.backends import make_backend
from latent_planner_ros.planning.cylinder_backend import CylinderBackend
from latent_planner_ros.robot.limits import Q_READY
from latent_planner_ros.robot.panda import load_panda

CYLS = np.array([[0.5, 0.0, 0.4, 0.05], [0.0, 0.5, 0.8, 0.08]])


@pytest.fixture()
def backend():
    torch.manual_seed(0)
    return CylinderBackend(CylinderClassifier(CylinderClassifierConfig(hidden=16, layers=2)))


def test_the_collision_loss_is_the_sum_over_obstacles(backend):
    backend.set_scene(CYLS)
    z = torch.randn(6, 7)
    p_each = backend.p_each(z)
    p = backend.p_collision(torch.zeros(6, 7), z)
    seed_loss = -torch.log1p(-p_each).sum(1)
    assert torch.allclose(-torch.log1p(-p), seed_loss, atol=1e-5)


def test_no_cylinders_means_no_collision(backend):
    backend.set_scene(np.zeros((0, 3)))  # the planner's "no scene"
    assert torch.all(backend.p_collision(torch.zeros(3, 7), torch.randn(3, 7)) == 0)
    assert not backend.check(np.tile(Q_READY, (3, 1))).any()


def test_the_hard_check_is_exact_or_off(backend):
    tcp = load_panda().fk(Q_READY).translation
    backend.set_scene(np.array([[tcp[0], tcp[1], tcp[2] + 0.05, 0.04]]))
    assert backend.check(Q_READY[None]).all()
    off = CylinderBackend(backend.classifier, check="none")
    off.set_scene(backend.cylinders)
    assert not off.check(Q_READY[None]).any()


def test_bad_input_is_refused(backend):
    with pytest.raises(ValueError, match="finite"):
        backend.set_scene(np.array([[0.5, np.inf, 0.4, 0.05]]))
    with pytest.raises(ValueError, match="check must be"):
        CylinderBackend(backend.classifier, check="sometimes")


def test_make_backend_reports_a_missing_classifier(tmp_path):
    from latent_planner_ros.models.checkpoint import CheckpointError

    with pytest.raises(CheckpointError, match="missing"):
        make_backend("cylinders", cylinder_checkpoint=str(tmp_path / "absent"))


def test_the_hard_check_keeps_its_margin_from_the_cylinders(backend):
    """A cylinder whose side lies within 5 mm of the arm is refused with the default 1 cm margin, not without one;
    the classifier still reads the given cylinders."""
    from latent_planner_ros.data.cylinders import cylinder_scene
    from latent_planner_ros.data.labels import CollisionLabeler

    q = Q_READY[None]
    gap = None
    for x in np.linspace(0.2, 0.9, 141):  # the nearest free spot in front of the arm along x, 5 mm steps
        cyl = np.array([[x, 0.0, 0.9, 0.05]])
        if not CollisionLabeler(cylinder_scene(cyl)).label(q).any():
            gap = cyl
            break
    assert gap is not None and gap[0, 0] > 0.2  # free, and 5 mm farther out than one that touches the arm
    backend.set_scene(gap)
    assert backend.check(q).all() and torch.equal(backend._o, torch.as_tensor(gap, dtype=torch.float32))
    exact = CylinderBackend(backend.classifier, margin_m=0.0)
    exact.set_scene(gap)
    assert not exact.check(q).any()
    with pytest.raises(ValueError, match="margin_m"):
        CylinderBackend(backend.classifier, margin_m=-0.01)

import pytest
import torch

from latent_planner_ros.models.vae_io import load_vae


@pytest.fixture(scope="session")
def shipped_vae():
    torch.set_num_threads(1)
    return load_vae()[0]

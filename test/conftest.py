"""Shared fixtures: every test starts from seeded RNGs and an isolated ROS domain."""

from __future__ import annotations

import os
import random

import numpy as np
import pytest
import torch

os.environ.setdefault("MUJOCO_GL", "osmesa")  # headless rendering (libosmesa6, installed by make setup)


@pytest.fixture(autouse=True)
def _seed_everything():
    random.seed(0)
    np.random.seed(0)
    torch.manual_seed(0)
    yield


@pytest.fixture
def rng() -> np.random.Generator:
    return np.random.default_rng(12345)


@pytest.fixture(scope="session", autouse=True)
def _ros_domain():
    """A random ROS_DOMAIN_ID per test session, so parallel runs on one machine do not talk."""
    os.environ.setdefault("ROS_DOMAIN_ID", str(random.SystemRandom().randint(1, 101)))
    os.environ.setdefault("RMW_IMPLEMENTATION", "rmw_fastrtps_cpp")
    yield

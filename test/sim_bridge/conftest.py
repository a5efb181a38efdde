"""Fixtures of the simulator tests: simulators that release their OpenGL context.

Importing any sim_bridge module first runs sim_bridge/__init__.py, which picks headless rendering (osmesa).
"""

from __future__ import annotations

import pytest

from sim_bridge.scenario_files import load_scenario
from sim_bridge.sim import Sim
from sim_bridge.sim_config import SimConfig


@pytest.fixture
def make_sim():
    """make_sim(scenario_name_or_Scenario, seed=0, **SimConfig fields) -> Sim, closed after the test."""
    sims = []

    def make(scenario="empty", seed=0, **config):
        if isinstance(scenario, str):
            scenario = load_scenario(scenario, seed)
        sim = Sim(scenario, SimConfig(seed=seed, **config))
        sims.append(sim)
        return sim

    yield make
    for sim in sims:
        sim.close()

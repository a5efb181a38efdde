"""Freed heap pages go back to the OS after a scene rebuild (the soak's memory figures of the sim)."""

from __future__ import annotations

import platform

import pytest

import sim_bridge.heap as heap
import sim_bridge.sim as sim_module
from sim_bridge.scenario_files import load_scenario
from sim_bridge.sim import Sim


@pytest.mark.skipif(platform.libc_ver()[0] != "glibc", reason="malloc_trim is glibc's")
def test_release_freed_memory_calls_malloc_trim_on_glibc():
    assert heap.release_freed_memory() is True


def test_release_freed_memory_without_malloc_trim_is_a_no_op(monkeypatch):
    monkeypatch.setattr(heap, "_libc", lambda: None)
    assert heap.release_freed_memory() is False


def test_every_scene_rebuild_releases_the_old_scenes_memory(monkeypatch):
    calls = []
    monkeypatch.setattr(sim_module, "release_freed_memory", lambda: calls.append(1) or True)
    sim = Sim(load_scenario("tabletop", seed=0))
    sim.reset(load_scenario("conveyor", seed=1))
    sim.close()
    assert len(calls) == 2  # the first build and the switch

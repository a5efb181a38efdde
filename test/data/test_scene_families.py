"""Every scene family by name: tabletop, each workcell family, their held-out variants and the groups."""

import numpy as np
import pytest

from latent_planner_ros.data.scene_families import family_names, generate_family_scene
from latent_planner_ros.data.workcell_generator import WORKCELL_FAMILIES


def test_every_name_makes_a_scene_and_unknown_names_are_refused():
    names = family_names()
    assert {"train", "heldout", "workcell", "mix", "mix_heldout"} <= set(names)
    assert all(f in names and f"{f}_heldout" in names for f in WORKCELL_FAMILIES)
    for k, name in enumerate(["train", "bookshelf", "cage_heldout", "workcell_heldout", "mix"]):
        scene = generate_family_scene(np.random.default_rng(k), name, seed=k)
        assert scene.obstacles and scene.seed == k
    with pytest.raises(ValueError, match="kitchen"):
        generate_family_scene(np.random.default_rng(0), "kitchen")


def test_a_mix_draws_tabletop_and_workcell_scenes():
    rng = np.random.default_rng(3)
    families = {generate_family_scene(rng, "mix").family for _ in range(12)}
    assert "train" in families and families - {"train"}

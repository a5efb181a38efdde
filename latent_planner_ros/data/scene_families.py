"""Every scene family by name: tabletop clutter and workcells, for training data and benchmarks alike.

Names:
- "train", "heldout": tabletop clutter (data/scene_generator.py; "heldout" = shapes never used in training);
- a workcell family ("bookshelf", "bin", "cage", "undershelf", "wall", "mixed"; data/workcell_generator.py),
  with its training variations, or "<family>_heldout" with the variations reserved for evaluation;
- "workcell" / "workcell_heldout": one workcell family drawn per scene;
- "mix" / "mix_heldout": tabletop or workcell, half each (a collision network's training set).
"""

from __future__ import annotations

import numpy as np

from latent_planner_ros.data.scene import Scene
from latent_planner_ros.data.scene_generator import FAMILIES as TABLETOP_FAMILIES
from latent_planner_ros.data.scene_generator import SceneGeneratorConfig, generate_scene

GROUPS = ("workcell", "mix")
"""names that draw one family per scene"""


def workcell_families() -> tuple[str, ...]:
    """The workcell families (data/workcell_generator.WORKCELL_FAMILIES)."""
    from latent_planner_ros.data.workcell_generator import WORKCELL_FAMILIES

    return tuple(WORKCELL_FAMILIES)


def family_names() -> list[str]:
    """Every accepted family name."""
    work = workcell_families()
    names = [*TABLETOP_FAMILIES, *work, *(f"{f}_heldout" for f in work)]
    return names + [*GROUPS, *(f"{g}_heldout" for g in GROUPS)]


def check_family(family: str) -> None:
    """ValueError naming the accepted families if `family` is not one of them."""
    if family not in family_names():
        raise ValueError(f"unknown scene family {family!r}; choose one of {family_names()}")


def generate_family_scene(
    rng: np.random.Generator, family: str, config: SceneGeneratorConfig | None = None, seed: int = -1
) -> Scene:
    """One random scene of `family` (see the module docstring); `config` shapes the tabletop scenes only and
    `seed` is recorded in the scene. Raises ValueError for an unknown family."""
    check_family(family)
    if family in TABLETOP_FAMILIES:
        return generate_scene(rng, family, config, seed=seed)
    heldout = family.endswith("_heldout")
    base = family.removesuffix("_heldout")
    if base == "mix":
        if rng.random() < 0.5:
            return generate_scene(rng, "heldout" if heldout else "train", config, seed=seed)
        base = "workcell"
    if base == "workcell":
        work = workcell_families()
        base = work[int(rng.integers(len(work)))]
    from latent_planner_ros.data.workcell_generator import generate_workcell

    return generate_workcell(rng, base, seed=seed, split="heldout" if heldout else "train")

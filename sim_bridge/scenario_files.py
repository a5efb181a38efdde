"""Scenario YAML files: finding them by name, and turning a file into a :class:`Scenario`.

A file either lists objects (a fixed, hand-written scene; schema in ``docs/scenarios.md``) or names a
seeded generator::

    name: tabletop
    generator: tabletop        # one of GENERATORS
    params: {min_objects: 4}   # the generator's parameter dataclass, all fields optional

Names are looked up as ``<name>.yaml`` in :func:`scenario_dirs`; a path to a file works too.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from latent_planner_ros.resources import resource_dirs
from sim_bridge.conveyor import ConveyorParams, conveyor
from sim_bridge.placement import params_from_dict
from sim_bridge.scenario import Scenario, ScenarioError, cameras_from_dict, scenario_from_dict
from sim_bridge.tabletop import TabletopParams, tabletop

PACKAGE = "latent_planner_ros"


def _empty(rng: np.random.Generator, params: None = None) -> Scenario:
    """The empty table."""
    return Scenario(name="empty", description="the bare table")


GENERATORS: dict[str, tuple[Callable[..., Scenario], type | None]] = {
    "tabletop": (tabletop, TabletopParams),
    "conveyor": (conveyor, ConveyorParams),
    "empty": (_empty, None),
}
"""Generator name -> (function(rng, params) -> Scenario, parameter dataclass or None)."""


def scenario_dirs() -> list[Path]:
    """Directories searched for ``<name>.yaml``, first match wins.

    ``$LATENT_PLANNER_SCENARIOS`` (os.pathsep-separated), then the source tree's ``config/scenarios`` (editable
    installs) and an install's ``share/latent_planner_ros/config/scenarios`` (ament index, install prefix,
    ``sys.prefix``), as :func:`latent_planner_ros.resources.resource_dirs` lists them.
    """
    dirs = [Path(p) for p in os.environ.get("LATENT_PLANNER_SCENARIOS", "").split(os.pathsep) if p]
    return list(dict.fromkeys([*dirs, *resource_dirs("config/scenarios")]))


def available_scenarios() -> list[str]:
    """Names of the scenario files found in :func:`scenario_dirs`, sorted."""
    names = {p.stem for d in scenario_dirs() if d.is_dir() for p in d.glob("*.yaml")}
    return sorted(names)


def find_scenario_file(name_or_path: str) -> Path:
    """The YAML file for a scenario name (``tabletop``) or path (``my/scene.yaml``).

    Raises:
        ScenarioError: naming the directories searched and the scenarios available.
    """
    try:
        path = Path(name_or_path).expanduser()
    except RuntimeError as err:  # "~someone/..." for a user this machine does not know
        raise ScenarioError(f"scenario path {name_or_path!r}: {err}") from None
    if path.suffix in (".yaml", ".yml") or os.sep in name_or_path:
        if path.is_file():
            return path
        raise ScenarioError(f"scenario file {str(path)!r} does not exist")
    for d in scenario_dirs():
        candidate = d / f"{name_or_path}.yaml"
        if candidate.is_file():
            return candidate
    searched = [str(d) for d in scenario_dirs() if d.is_dir()]
    raise ScenarioError(
        f"unknown scenario {name_or_path!r}: no {name_or_path}.yaml in {searched}; available: {available_scenarios()}"
    )


def scenario_from_spec(data: Any, seed: int | None, overrides: Mapping[str, Any] | None = None) -> Scenario:
    """A Scenario from a parsed file: fixed scenes are validated, generator files are run with `seed`.

    Args:
        data: the parsed YAML mapping.
        seed: seed of the generator's numpy Generator (None: fresh entropy); unused for fixed scenes.
        overrides: generator parameters that replace the file's ``params`` entries.

    Raises:
        ScenarioError: naming the offending field.
    """
    if not isinstance(data, Mapping):
        raise ScenarioError(f"expected a mapping at the top level, got {type(data).__name__}")
    if "generator" not in data:
        if overrides:
            raise ScenarioError(f"overrides {sorted(overrides)} given for a fixed scene (only generators take params)")
        return scenario_from_dict(data)
    allowed = {"name", "description", "generator", "params", "cameras"}
    unknown = sorted(set(map(str, data)) - allowed)
    if unknown:
        raise ScenarioError(f"{unknown[0]}: unknown field in a generator file (allowed: {sorted(allowed)})")
    kind = data["generator"]
    if kind not in GENERATORS:
        raise ScenarioError(f"generator: expected one of {sorted(GENERATORS)}, got {kind!r}")
    function, params_cls = GENERATORS[kind]
    params = data.get("params") or {}
    if not isinstance(params, Mapping):
        raise ScenarioError("params: expected a mapping of generator parameters")
    params = {**params, **(overrides or {})}
    if params_cls is None:
        if params:
            raise ScenarioError(f"params.{sorted(params)[0]}: the {kind} generator takes no parameters")
        result = function(np.random.default_rng(seed))
    else:
        result = function(np.random.default_rng(seed), params_from_dict(params_cls, params, "params"))
    name = data.get("name", kind)
    cameras = cameras_from_dict(data.get("cameras"))
    return Scenario(
        name=str(name), objects=result.objects, target=result.target, description=result.description, cameras=cameras
    )


def load_scenario(name_or_path: str, seed: int | None = 0, overrides: Mapping[str, Any] | None = None) -> Scenario:
    """Load a scenario by name or path (see :func:`scenario_from_spec`); errors name the file and field."""
    path = find_scenario_file(name_or_path)
    try:
        data = yaml.safe_load(path.read_text())
    except yaml.YAMLError as err:
        raise ScenarioError(f"{path}: not valid YAML: {err}") from None
    try:
        return scenario_from_spec(data, seed, overrides)
    except ScenarioError as err:
        raise ScenarioError(f"{path}: {err}") from None


def parse_overrides(text: str) -> dict[str, Any]:
    """Generator parameter overrides from a YAML/JSON mapping string such as ``"{speed: 0.1}"`` ('' = none)."""
    if not text.strip():
        return {}
    try:
        data = yaml.safe_load(text)
    except yaml.YAMLError as err:
        raise ScenarioError(f"scenario_overrides: not valid YAML: {err}") from None
    if not isinstance(data, Mapping):
        raise ScenarioError(f"scenario_overrides: expected a mapping such as '{{speed: 0.1}}', got {text!r}")
    return dict(data)

"""Scenario files: lookup by name or path, generator files, overrides, and errors that name the field."""

from __future__ import annotations

from pathlib import Path

import pytest

from sim_bridge.scenario import ScenarioError
from sim_bridge.scenario_files import (
    available_scenarios,
    find_scenario_file,
    load_scenario,
    parse_overrides,
    scenario_from_spec,
)

REPO = Path(__file__).resolve().parents[2]
SHIPPED = sorted(p.stem for p in (REPO / "config" / "scenarios").glob("*.yaml"))


def test_shipped_scenarios_are_found_by_name():
    assert {"empty", "tabletop", "conveyor"} <= set(SHIPPED)
    assert set(SHIPPED) <= set(available_scenarios())
    for name in SHIPPED:
        assert find_scenario_file(name) == REPO / "config" / "scenarios" / f"{name}.yaml"


@pytest.mark.parametrize("name", SHIPPED)
def test_every_shipped_scenario_loads(name):
    a, b = load_scenario(name, seed=1), load_scenario(name, seed=1)
    assert a == b and a.name == name


def test_seed_changes_generated_scenes():
    assert load_scenario("tabletop", seed=1) != load_scenario("tabletop", seed=2)


def test_overrides_replace_generator_params():
    fast = load_scenario("conveyor", seed=0, overrides=parse_overrides("{speed: 0.2, mode: bounce}"))
    assert fast.object("target").motion.velocity[1] == 0.2 and fast.object("target").motion.mode == "bounce"
    with pytest.raises(ScenarioError, match=r"params\.sped: unknown parameter"):
        load_scenario("conveyor", overrides={"sped": 0.2})
    with pytest.raises(ScenarioError, match="scenario_overrides"):
        parse_overrides("[1, 2]")


def test_bad_file_names_file_and_field(tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_text("name: bad\nobjects:\n  - {name: a, type: sphere, radius: -0.1, position: [0.5, 0, 0.1]}\n")
    with pytest.raises(ScenarioError, match=r"bad\.yaml: objects\[0\]\.radius: expected a positive number"):
        load_scenario(str(bad))
    bad.write_text("name: bad\ngenerator: tabletop\nparams: {max_objects: 3}\n")
    with pytest.raises(ScenarioError, match=r"bad\.yaml: params\.min_objects"):
        load_scenario(str(bad))
    bad.write_text("objects: [\n")
    with pytest.raises(ScenarioError, match="not valid YAML"):
        load_scenario(str(bad))


def test_unknown_scenario_lists_the_available_ones():
    with pytest.raises(ScenarioError, match="available: .*tabletop"):
        load_scenario("no_such_scene")
    with pytest.raises(ScenarioError, match="does not exist"):
        load_scenario("/nonexistent/scene.yaml")


def test_spec_errors():
    with pytest.raises(ScenarioError, match="generator: expected one of"):
        scenario_from_spec({"generator": "forest"}, seed=0)
    with pytest.raises(ScenarioError, match="objects: unknown field in a generator file"):
        scenario_from_spec({"generator": "empty", "objects": []}, seed=0)
    with pytest.raises(ScenarioError, match="only generators take params"):
        scenario_from_spec({"objects": []}, seed=0, overrides={"speed": 1})


def test_the_documented_example_scene_loads(tmp_path):
    doc = (REPO / "docs" / "scenarios.md").read_text()
    section = doc.split("## Writing a fixed scene", 1)[1]
    example = section.split("```yaml", 1)[1].split("```", 1)[0]
    path = tmp_path / "example.yaml"
    path.write_text(example)
    scenario = load_scenario(str(path))
    assert [o.type for o in scenario.objects] == ["box", "cylinder", "sphere", "mesh"]
    assert scenario.target.object == "ball" and scenario.object("ball").motion.mode == "bounce"

"""docs/nodes.md is kept true: its tables are compared with what every node in registry.NODES declares.

Parameters come from the node's source: each `declare_parameter` call is either a literal ("name", default)
or the loop over `to_params(SomeConfig())`, whose flat names and defaults are the declared ones. Topics and
services come from the node's `create_publisher` / `create_subscription` / `create_service` calls, whose
names are string literals, or names made from parameters: an f-string (`f"{camera}/points"` is documented as
`<camera>/points`) or a variable (`cloud_topic` is documented as `<cloud_topic>`). Numeric valid ranges in the
doc are checked at their boundaries against the config's validation. A node, parameter, topic or service that
is added or renamed fails here until the doc says so.
"""

from __future__ import annotations

import ast
import importlib
import importlib.util
import re
from pathlib import Path

import pytest
import yaml

from latent_planner_ros.params.config import from_params, to_params
from latent_planner_ros.registry import NODES

ROOT = Path(__file__).resolve().parent.parent
DOC = ROOT / "docs" / "nodes.md"
KINDS = {"create_publisher": "publishes", "create_subscription": "subscribes", "create_service": "service"}
NUM = r"-?\d+(?:\.\d+)?(?:e-?\d+)?"


# -- the doc -------------------------------------------------------------------------------------
def _table(text: str) -> list[list[str]]:
    """Rows (header and separator dropped) of the first markdown table in `text`, cells without backticks."""
    rows = [line for line in text.splitlines() if line.startswith("|")]
    return [[c.strip().strip("`") for c in row.strip().strip("|").split(" | ")] for row in rows[2:]]


def doc_sections() -> dict[str, dict[str, str]]:
    """{node: {"Topics" | "Services" | "Parameters": text}} from the `## node` / `### part` headings."""
    out = {}
    for block in re.split(r"^## ", DOC.read_text(), flags=re.M)[1:]:
        name, _, body = block.partition("\n")
        parts = re.split(r"^### ", body, flags=re.M)[1:]
        out[name.strip()] = {p.partition("\n")[0].strip(): p.partition("\n")[2] for p in parts}
    return out


def doc_params(node: str) -> dict[str, dict[str, str]]:
    """{parameter: {type, default, unit, range}} of the node's parameter table."""
    rows = _table(doc_sections()[node]["Parameters"])
    return {r[0]: {"type": r[1], "default": r[2], "unit": r[3], "range": r[4]} for r in rows}


def doc_interfaces(node: str) -> set[tuple[str, str, str]]:
    """{(kind, name, type)}: kind "publishes" / "subscribes" from the topic table, "service" from the other."""
    parts = doc_sections()[node]
    topics = {(r[2], r[0], r[1]) for r in _table(parts["Topics"])}
    return topics | {("service", r[0], r[1]) for r in _table(parts["Services"])}


# -- the code ------------------------------------------------------------------------------------
def _module(node: str) -> str:
    return NODES[node].split(":")[0]


def _tree(node: str) -> ast.Module:
    return ast.parse(Path(importlib.util.find_spec(_module(node)).origin).read_text())


def _calls(tree: ast.Module, attr: str) -> list[ast.Call]:
    calls = [n for n in ast.walk(tree) if isinstance(n, ast.Call) and isinstance(n.func, ast.Attribute)]
    return [n for n in calls if n.func.attr == attr]


def declared_params(node: str) -> tuple[dict[str, object], type | None]:
    """({name: default} the node declares, the config dataclass they come from or None)."""
    tree = _tree(node)
    params, config = {}, None
    found = re.findall(r"ConfigParams\(self, (\w+)", ast.unparse(tree))  # latent_planner_ros/params/ros.py
    if found:
        config = getattr(importlib.import_module(_module(node)), found[0])
        params.update(to_params(config()))
    for call in _calls(tree, "declare_parameter"):
        first = call.args[0]
        if found:  # the loop over a named camera's fields (sim): documented as <camera>.*
            continue
        if isinstance(first, ast.Constant):
            params[first.value] = ast.literal_eval(call.args[1]) if len(call.args) > 1 else None
            continue
        found = re.findall(r"to_params\((\w+)\(\)\)", ast.unparse(tree))
        assert len(found) == 1, f"{node}: declare parameters literally or from one to_params(Config())"
        config = getattr(importlib.import_module(_module(node)), found[0])
        params.update(to_params(config()))
    return params, config


def _interface_name(node: str, call: ast.Call, attr: str) -> str:
    """The name argument of a create_* call: the literal, or `<expr>` for each part computed at run time."""
    name = call.args[1]
    if isinstance(name, ast.Constant):
        return name.value
    if isinstance(name, ast.JoinedStr):
        parts = [v.value if isinstance(v, ast.Constant) else f"<{ast.unparse(v.value)}>" for v in name.values]
        return "".join(parts)
    assert isinstance(name, ast.Name), f"{node}: {attr} at line {call.lineno} needs a literal, f-string or variable"
    return f"<{name.id}>"


def declared_interfaces(node: str) -> set[tuple[str, str, str]]:
    """{(kind, name, "pkg/Type")} from the node's create_* calls (names must be string literals)."""
    tree = _tree(node)
    packages = {
        alias.asname or alias.name: n.module.split(".")[0]
        for n in ast.walk(tree)
        if isinstance(n, ast.ImportFrom) and n.module and n.module.endswith((".msg", ".srv"))
        for alias in n.names
    }
    out = set()
    for attr, kind in KINDS.items():
        for call in _calls(tree, attr):
            cls, name = call.args[0], _interface_name(node, call, attr)
            assert isinstance(cls, ast.Name) and cls.id in packages, f"{node}: line {call.lineno}: unknown type"
            out.add((kind, name, f"{packages[cls.id]}/{cls.id}"))
    for call in ast.walk(tree):  # nodes/qos.py: a cloud subscription with its publishers' reliability
        if isinstance(call, ast.Call) and isinstance(call.func, ast.Name) and call.func.id == "CloudSubscription":
            out.add(("subscribes", _interface_name(node, call, "CloudSubscription"), "sensor_msgs/PointCloud2"))
    return out


def ros_type(value: object) -> str:
    if isinstance(value, bool):
        return "bool"
    if isinstance(value, int):
        return "integer"
    if isinstance(value, float):
        return "double"
    if isinstance(value, str):
        return "string"
    if isinstance(value, list | tuple) and value:
        return ros_type(value[0]) + "[]"
    raise AssertionError(f"no ROS parameter type for {value!r}")


# -- tests ---------------------------------------------------------------------------------------
def test_every_node_has_a_section_and_no_other():
    sections = doc_sections()
    assert set(sections) == set(NODES)
    for node, parts in sections.items():
        assert {"Topics", "Services", "Parameters"} <= set(parts), node


@pytest.mark.parametrize("node", sorted(NODES))
def test_parameters_match_the_declared_ones(node):
    declared, _ = declared_params(node)
    if not declared:
        assert doc_sections()[node]["Parameters"].strip() == "None.", f"{node} declares no parameters"
        return
    doc = doc_params(node)
    assert sorted(set(declared) - set(doc)) == [], f"{node}: declared but not in docs/nodes.md"
    assert sorted(set(doc) - set(declared)) == [], f"{node}: in docs/nodes.md but not declared"
    for name, value in declared.items():
        row = doc[name]
        assert row["type"] == ros_type(value), f"{node} {name}: type"
        value = list(value) if isinstance(value, tuple) else value
        assert yaml.safe_load(row["default"]) == value, f"{node} {name}: default {row['default']} != {value!r}"
        assert row["unit"] and row["range"], f"{node} {name}: unit and valid range must be given"


@pytest.mark.parametrize("node", sorted(NODES))
def test_topics_and_services_match_the_declared_ones(node):
    declared, doc = declared_interfaces(node), doc_interfaces(node)
    assert sorted(declared - doc) == [], f"{node}: declared but not in docs/nodes.md"
    assert sorted(doc - declared) == [], f"{node}: in docs/nodes.md but not declared"


def _accepts(config: type, name: str, value: object) -> bool:
    try:
        from_params(config, {name: value})
    except (ValueError, TypeError):
        return False
    return True


def range_cases(kind: str, text: str) -> list[tuple[object, bool]]:
    """(value, accepted?) pairs probing the boundaries of a documented range; [] if it is not a plain one."""
    integer = kind == "integer"
    num = int if integer else float

    def step(bound: float) -> float:
        return 1 if integer else 1e-6 * max(1.0, abs(bound))

    m = re.fullmatch(rf"([\[(])({NUM}), ({NUM})([\])])", text)
    if m:
        lo, hi = num(float(m[2])), num(float(m[3]))
        low = [(lo, False), (lo + step(lo), True)] if m[1] == "(" else [(lo, True), (lo - step(lo), False)]
        high = [(hi, False), (hi - step(hi), True)] if m[4] == ")" else [(hi, True), (hi + step(hi), False)]
        return low + high
    m = re.fullmatch(rf"(>=?) ({NUM})", text)
    if m:
        lo = num(float(m[2]))
        return [(lo, False), (lo + step(lo), True)] if m[1] == ">" else [(lo, True), (lo - step(lo), False)]
    m = re.fullmatch(r"\{(.+)\}", text)
    if m:
        return [(c.strip(), True) for c in m[1].split(",")] + [("no-such-choice", False)]
    return []


@pytest.mark.parametrize("node", sorted(NODES))
def test_documented_ranges_hold_at_their_boundaries(node):
    declared, config = declared_params(node)
    if config is None or not any(r["type"] in ("integer", "double") for r in doc_params(node).values()):
        return
    checked = 0
    for name, row in doc_params(node).items():
        for value, accepted in range_cases(row["type"], row["range"]):
            assert _accepts(config, name, value) == accepted, f"{node} {name} = {value!r}: range {row['range']}"
            checked += 1
    assert checked > 0, f"{node}: no documented range could be checked"


def test_readme_links_the_node_reference():
    assert "docs/nodes.md" in (ROOT / "README.md").read_text()

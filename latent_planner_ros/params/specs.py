"""What a ROS parameter descriptor says about each field of a config dataclass: type, description, range,
read-only. No ROS (msg_adapters/parameters.py turns a ParamSpec into an rcl_interfaces ParameterDescriptor).

Descriptions are the configs' own field docs, read once from the source with `ast`: the string literal right
under a field (``rate_hz: float = 10.0`` then ``\"\"\"control rate [Hz]\"\"\"``), or the field's entry in an
``Attributes:`` section of the class docstring. Ranges come from a small table next to each config, written in
the notation of docs/nodes.md: ``"[0, 3600]"``, ``"(0, 100]"``, ``"[0, 1)"``, ``"> 0"``, ``">= 1"``.
"""

from __future__ import annotations

import ast
import dataclasses
import inspect
import re
import textwrap
from collections.abc import Mapping
from dataclasses import dataclass
from functools import cache
from typing import Any

from latent_planner_ros.params.config import to_params

_NUM = r"-?\d+(?:\.\d+)?(?:e-?\d+)?"


@dataclass(frozen=True)
class Range:
    """A numeric range: low/high bounds (None = unbounded) and whether each end is excluded."""

    low: float | None
    high: float | None = None
    open_low: bool = False
    open_high: bool = False

    @classmethod
    def parse(cls, text: str) -> Range:
        """`"[a, b]"`, `"(a, b]"`, `"[a, b)"`, `"(a, b)"`, `"> a"` or `">= a"` (ValueError otherwise)."""
        m = re.fullmatch(rf"([\[(])({_NUM}), ({_NUM})([\])])", text.strip())
        if m:
            return cls(float(m[2]), float(m[3]), m[1] == "(", m[4] == ")")
        m = re.fullmatch(rf"(>=?) ({_NUM})", text.strip())
        if m:
            return cls(float(m[2]), None, m[1] == ">")
        raise ValueError(f"not a range: {text!r}")

    @property
    def bounded(self) -> bool:
        return self.low is not None and self.high is not None

    def __str__(self) -> str:
        if self.high is None:
            return f"{'>' if self.open_low else '>='} {self.low:g}"
        return f"{'(' if self.open_low else '['}{self.low:g}, {self.high:g}{')' if self.open_high else ']'}"


RangeTable = Mapping[type, Mapping[str, str]]
"""{config class: {field name: range text}}, e.g. {ClosedLoopConfig: {"rate_hz": "> 0"}}."""


@dataclass(frozen=True)
class ParamSpec:
    """One ROS parameter of a config.

    Attributes:
        name: full dotted name (``closed_loop.rate_hz``).
        value: default value (tuples as lists).
        type: "bool", "integer", "double", "string", "bool[]", "integer[]", "double[]" or "string[]".
        description: the field's doc (units in brackets, as written there).
        range: the valid range, or None when not a plain numeric range.
        read_only: changing it needs a restart (ROS refuses every set).
    """

    name: str
    value: Any
    type: str
    description: str
    range: Range | None = None
    read_only: bool = False


@cache
def field_docs(cls: type) -> dict[str, str]:
    """{field: doc} of a dataclass, whitespace collapsed, from its source (and its bases'); {} without source."""
    docs: dict[str, str] = {}
    for klass in reversed(cls.__mro__[:-1]):
        try:
            tree = ast.parse(textwrap.dedent(inspect.getsource(klass)))
        except (OSError, TypeError, SyntaxError):
            continue
        body = tree.body[0].body if tree.body and isinstance(tree.body[0], ast.ClassDef) else []
        docs.update(_attributes_section(ast.get_docstring(tree.body[0]) or "") if body else {})
        for stmt, following in zip(body, body[1:], strict=False):
            if isinstance(stmt, ast.AnnAssign) and isinstance(stmt.target, ast.Name):
                if isinstance(following, ast.Expr) and isinstance(following.value, ast.Constant):
                    if isinstance(following.value.value, str):
                        docs[stmt.target.id] = " ".join(following.value.value.split())
    return docs


def _attributes_section(docstring: str) -> dict[str, str]:
    """{name: text} of a Google-style ``Attributes:`` section (``a, b: text`` documents both a and b)."""
    out: dict[str, str] = {}
    _, found, rest = docstring.partition("Attributes:")
    if not found:
        return out
    names: list[str] = []
    for line in rest.splitlines():
        m = re.match(r"\s{4}(\w+(?:, \w+)*): (.*)", line)
        if m:
            names = m[1].split(", ")
            for n in names:
                out[n] = m[2].strip()
        elif line.startswith("        ") and names:
            for n in names:
                out[n] += " " + line.strip()
        elif line.strip() and not line.startswith(" "):
            break
    return out


def _ros_type(value: Any, annotation: str) -> str:
    for py, ros in ((bool, "bool"), (int, "integer"), (float, "double"), (str, "string")):
        if isinstance(value, py):
            return ros
    if isinstance(value, list | tuple):
        if value:
            return _ros_type(value[0], "") + "[]"
        for word, ros in (("str", "string"), ("float", "double"), ("int", "integer"), ("bool", "bool")):
            if word in annotation:
                return ros + "[]"
    raise TypeError(f"no ROS parameter type for {value!r} ({annotation})")


def _fields(config: Any, prefix: str = ""):
    """(dotted name, owning dataclass type, field) of every leaf field of a nested config."""
    for f in dataclasses.fields(config):
        value = getattr(config, f.name)
        if dataclasses.is_dataclass(value):
            yield from _fields(value, prefix + f.name + ".")
        else:
            yield prefix + f.name, type(config), f


def param_specs(config: Any, ranges: RangeTable = {}, read_only=()) -> dict[str, ParamSpec]:  # noqa: B006
    """{dotted name: ParamSpec} of every parameter of `config` (an instance: its values are the defaults).

    ranges: range texts per config class and field; read_only: dotted names that need a restart.
    Raises ValueError for a read_only name that is not a parameter.
    """
    values = to_params(config)
    unknown = sorted(set(read_only) - set(values))
    if unknown:
        raise ValueError(f"read_only names no parameter: {unknown}")
    out = {}
    for name, owner, f in _fields(config):
        text = ranges.get(owner, {}).get(f.name)
        out[name] = ParamSpec(
            name=name,
            value=values[name],
            type=_ros_type(values[name], str(f.type)),
            description=field_docs(owner).get(f.name, ""),
            range=Range.parse(text) if text else None,
            read_only=name in read_only,
        )
    return out

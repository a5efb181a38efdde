"""Config dataclasses <-> flat ROS parameter dictionaries, and the checks the configs use.

A nested dataclass field becomes a dotted prefix (``camera.width``), which is how a ROS 2 parameter
YAML nests (``sim: ros__parameters: camera: width: 320``). Tuples become lists (ROS arrays).
"""

from __future__ import annotations

import dataclasses
import math
import re
from collections.abc import Mapping
from typing import Any, TypeVar, cast

C = TypeVar("C")


class ConfigError(ValueError):
    """A configuration value is refused; the message names the parameter and the reason."""


def to_params(config: Any, prefix: str = "") -> dict[str, Any]:
    """Flat {name: value} of a (nested) config dataclass, e.g. {"seed": 0, "camera.width": 320}."""
    out: dict[str, Any] = {}
    for f in dataclasses.fields(config):
        value = getattr(config, f.name)
        name = prefix + f.name
        if dataclasses.is_dataclass(value):
            out.update(to_params(value, name + "."))
        else:
            out[name] = list(value) if isinstance(value, tuple) else value
    return out


def from_params(cls: type[C], params: Mapping[str, Any], base: C | None = None, prefix: str = "") -> C:
    """A config of type `cls` from a flat {name: value}; names not given keep `base`'s (or the default) value.

    Raises:
        ConfigError: an unknown parameter name, or a value the config refuses (naming the parameter).
    """
    base = base if base is not None else cls()
    if not prefix:
        known = set(to_params(base))
        unknown = sorted(set(params) - known)
        if unknown:
            raise ConfigError(f"{unknown[0]}: unknown parameter")
    kwargs: dict[str, Any] = {}
    for f in dataclasses.fields(cast(Any, cls)):
        name = prefix + f.name
        current: Any = getattr(base, f.name)
        if dataclasses.is_dataclass(current):
            kwargs[f.name] = from_params(type(current), params, current, name + ".")
        elif name in params:
            value = params[name]
            kwargs[f.name] = tuple(value) if isinstance(current, tuple) and not isinstance(value, str) else value
        else:
            kwargs[f.name] = current
    try:
        return cls(**kwargs)
    except (ConfigError, ValueError, TypeError) as err:
        raise ConfigError(qualify(str(err), prefix, [f.name for f in dataclasses.fields(cast(Any, cls))])) from None


def qualify(message: str, prefix: str, names) -> str:
    """`message` with every "; "-separated problem that starts with a field name given its full dotted name
    (`rate_hz must be ...` -> `closed_loop.rate_hz must be ...`); problems naming no field keep their text."""
    if not prefix:
        return message
    names = set(names)
    parts = []
    for part in message.split("; "):
        head = re.match(r"(?:\w+\.)?(\w+)", part)  # a config may already say "ik.pos_tol"
        if head and head.group(1) in names:
            part = prefix + head.group(1) + part[head.end() :]
        parts.append(part)
    return "; ".join(parts)


MIN_RATE_HZ = 0.01
"""lowest rate [Hz] a rate parameter takes: its timer's period (100 s at most) must be a finite count of
nanoseconds (a rate of 1e-320 Hz passed "> 0" and gave an infinite period)"""


def check_number(name: str, value: Any, low: float | None = None, high: float | None = None, open_low=False) -> None:
    """ConfigError unless value is a finite real in [low, high] (or (low, high] with open_low)."""
    ok = isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(value)
    if ok and low is not None:
        ok = value > low if open_low else value >= low
    if ok and high is not None:
        ok = value <= high
    if not ok:
        lo = "(" if open_low else "["
        raise ConfigError(f"{name}: expected a number in {lo}{low}, {high}], got {value!r}")


def check_int(name: str, value: Any, low: int, high: int) -> None:
    """ConfigError unless value is an integer in [low, high]."""
    if not isinstance(value, int) or isinstance(value, bool) or not low <= value <= high:
        raise ConfigError(f"{name}: expected an integer in [{low}, {high}], got {value!r}")


def check_vector(name: str, value: Any, n: int) -> None:
    """ConfigError unless value is a sequence of n finite reals."""
    ok = isinstance(value, tuple | list) and len(value) == n
    ok = ok and all(isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v) for v in value)
    if not ok:
        raise ConfigError(f"{name}: expected {n} finite numbers, got {value!r}")

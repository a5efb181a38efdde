"""Declaring a config dataclass as ROS parameters on a node: static types, descriptors, screened changes.

Every node of the suite declares its parameters through :class:`ConfigParams`:

- each parameter is statically typed (the type of its default) and carries a descriptor: the field's doc as
  description, a FloatingPointRange / IntegerRange where the config's table gives a bounded range (the range
  text, e.g. ``(0, 100]`` or ``> 0``, also in ``additional_constraints``: ROS ranges are closed, the config's
  validation refuses an excluded end), and read_only where a change needs a restart;
- an integer given for a double parameter (``rate_hz: 20`` in a YAML, ``ros2 param set ... rate_hz 20``) is
  taken as that double, at start-up and at run time; the parameter stays a double. Any other type is refused
  with the full dotted name (``closed_loop.rate_hz: expected double, got bool True``);
- a change reaches the node's callback as {dotted name: value} of its own parameters only (``use_sim_time``
  and other parameters of rclpy pass through, accepted);
- further parameters outside the config (the sim's ``<camera>.*`` groups) can be declared the same way with
  :meth:`ConfigParams.declare`: same descriptors, start-up checks and type screening; their changes go to the
  node's own callback.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any

from rcl_interfaces.msg import FloatingPointRange, IntegerRange, ParameterDescriptor, SetParametersResult
from rclpy.exceptions import InvalidParameterTypeException, InvalidParameterValueException
from rclpy.parameter import Parameter

from latent_planner_ros.params.config import ConfigError, from_params
from latent_planner_ros.params.specs import ParamSpec, RangeTable, param_specs

TYPES = {
    "bool": Parameter.Type.BOOL,
    "integer": Parameter.Type.INTEGER,
    "double": Parameter.Type.DOUBLE,
    "string": Parameter.Type.STRING,
    "bool[]": Parameter.Type.BOOL_ARRAY,
    "integer[]": Parameter.Type.INTEGER_ARRAY,
    "double[]": Parameter.Type.DOUBLE_ARRAY,
    "string[]": Parameter.Type.STRING_ARRAY,
}
"""ParamSpec.type -> rclpy parameter type."""

_TYPE_WORDS = {t: name for name, t in TYPES.items()}


def descriptor(spec: ParamSpec) -> ParameterDescriptor:
    """The static-typed ParameterDescriptor of a ParamSpec (ranges only for bounded numeric ones)."""
    d = ParameterDescriptor(
        name=spec.name,
        type=TYPES[spec.type].value,
        description=spec.description,
        read_only=spec.read_only,
        dynamic_typing=False,
    )
    r = spec.range
    if r is not None:
        d.additional_constraints = f"valid range {r}"
        if r.bounded and spec.type == "double":
            d.floating_point_range = [FloatingPointRange(from_value=r.low, to_value=r.high, step=0.0)]
        elif r.bounded and spec.type == "integer":
            d.integer_range = [IntegerRange(from_value=int(r.low), to_value=int(r.high), step=0)]
    return d


def coerce(spec: ParamSpec, value: Any) -> tuple[bool, Any]:
    """(ok, value) of `value` for spec's type: integers become doubles for double parameters, nothing else
    changes type (bools are not numbers here)."""
    expected = TYPES[spec.type]
    given = Parameter.Type.from_parameter_value(value) if value is not None else Parameter.Type.NOT_SET
    if given == expected:
        return True, value
    if expected == Parameter.Type.DOUBLE and given == Parameter.Type.INTEGER:
        return True, float(value)
    if expected == Parameter.Type.DOUBLE_ARRAY and given == Parameter.Type.INTEGER_ARRAY:
        return True, [float(v) for v in value]
    return False, value


def type_refusal(spec: ParamSpec, value: Any) -> str:
    given = Parameter.Type.from_parameter_value(value) if value is not None else Parameter.Type.NOT_SET
    return f"{spec.name}: expected {spec.type}, got {_TYPE_WORDS.get(given, 'no value')} {value!r}"


ROS_OWN_PARAMETERS = ("use_sim_time", "start_type_description_service")
"""parameters rclpy declares on every node (and `qos_overrides.*`)"""


def undeclared_overrides(node) -> list[str]:
    """Names given at start-up (a parameters file, `-p NAME:=VALUE`) that `node` never declared: rclpy drops them
    silently, so a misspelt or unknown parameter would look applied. Call once the node declared everything."""
    overrides = getattr(node, "_parameter_overrides", {})
    return sorted(
        name
        for name in overrides
        if not node.has_parameter(name) and name not in ROS_OWN_PARAMETERS and not name.startswith("qos_overrides.")
    )


class ConfigParams:
    """The parameters of one config dataclass on `node`, declared with descriptors; `config` holds the start-up
    values (validated: ConfigError naming the parameter).

    Args:
        node: the rclpy node.
        config_cls: the config dataclass; `defaults` (an instance) gives other defaults than config_cls().
        ranges: range texts per config class and field (latent_planner_ros.params.specs.RangeTable).
        read_only: dotted names whose change needs a restart.
    """

    def __init__(self, node, config_cls: type, defaults=None, ranges: RangeTable = {}, read_only=()):  # noqa: B006
        self.node = node
        self.specs = param_specs(defaults if defaults is not None else config_cls(), ranges, read_only)
        self._more: dict[str, ParamSpec] = {}  # parameters declared by `declare`, outside the config
        self._refusals: list[str] = []
        for spec in self.specs.values():
            self._declare(spec)
        self.config = from_params(config_cls, self.values())
        node.add_pre_set_parameters_callback(self._pre_set)

    def declare(self, specs: Mapping[str, ParamSpec]) -> dict[str, Any]:
        """Declare parameters outside the config ({name: spec}, each spec named by its full name) as the config's
        are (ConfigError naming a bad start-up value); {name: current value}. A wrong type is refused with the name
        as for the config's; the node's own set-parameters callback applies their changes."""
        for name, spec in specs.items():
            self._declare(spec)
            self._more[name] = spec
        return {name: _plain(self.node.get_parameter(name).value) for name in specs}

    def _declare(self, spec: ParamSpec) -> None:
        overrides = getattr(self.node, "_parameter_overrides", {})  # YAML / -p values, before declaring them
        if spec.name in overrides:
            ok, value = coerce(spec, overrides[spec.name].value)
            if not ok:
                raise ConfigError(type_refusal(spec, overrides[spec.name].value))
            overrides[spec.name] = Parameter(spec.name, TYPES[spec.type], value)
        try:
            self.node.declare_parameter(spec.name, spec.value, descriptor(spec))
        except InvalidParameterValueException:  # outside the descriptor's range
            value = overrides[spec.name].value if spec.name in overrides else spec.value
            raise ConfigError(f"{spec.name}: {value!r} is outside its valid range {spec.range}") from None
        except InvalidParameterTypeException as err:
            raise ConfigError(f"{spec.name}: {err}") from None

    @property
    def names(self) -> dict[str, Any]:
        """{dotted name: default value}."""
        return {n: s.value for n, s in self.specs.items()}

    def values(self) -> dict[str, Any]:
        """{dotted name: current value} (arrays as lists)."""
        out = {}
        for name in self.specs:
            value = self.node.get_parameter(name).value
            out[name] = list(value) if not isinstance(value, str | bytes) and hasattr(value, "__len__") else value
        return out

    def _pre_set(self, params: list[Parameter]) -> list[Parameter]:
        """Integers for doubles become doubles; a value of another type is replaced by the current one and
        remembered, so the set is refused with the parameter's name (rclpy's own message names none)."""
        self._refusals = []
        out = []
        for p in params:
            spec = self.specs.get(p.name) or self._more.get(p.name)
            if spec is None or p.type_ == Parameter.Type.NOT_SET:
                out.append(p)
                continue
            ok, value = coerce(spec, p.value)
            if ok:
                out.append(Parameter(p.name, TYPES[spec.type], value) if value is not p.value else p)
            else:
                self._refusals.append(type_refusal(spec, p.value))
                out.append(self.node.get_parameter(p.name))
        return out

    def on_set(self, callback: Callable[[Mapping[str, Any]], SetParametersResult]) -> None:
        """Call `callback` with {dotted name: value} of the changed parameters of this config (never empty);
        type refusals are answered before it, other parameters (use_sim_time, ...) are accepted."""

        def screened(params: list[Parameter]) -> SetParametersResult:
            refusals, self._refusals = self._refusals, []
            if refusals:
                return SetParametersResult(successful=False, reason="; ".join(refusals))
            ours = {p.name: _plain(p.value) for p in params if p.name in self.specs}
            return callback(ours) if ours else SetParametersResult(successful=True)

        self.node.add_on_set_parameters_callback(screened)


def _plain(value: Any) -> Any:
    return list(value) if not isinstance(value, str | bytes) and hasattr(value, "__len__") else value

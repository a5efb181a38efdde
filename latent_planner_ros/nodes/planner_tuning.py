"""The planner node's tuning file: the settings that are not ROS parameters, as a YAML of config-class fields.

The node's parameters are the ones a user tunes (nodes/planner_config.py). Everything else of AMP-LS, LSPP and
the closed loop keeps its default in its config class and can be changed, for experiments, by a YAML file named
in the read-only parameter `tuning_file`:

    amp_ls:                      # amp_ls/config.py, dotted for a part's field; a part set to null is off
      search.restarts: 4
      escape: null
    lspp:
      checks.backtrace_keep: 0.25
    closed_loop:                 # planning/closed_loop.py ClosedLoopConfig
      plan_wait_s: 0.5
    obstacle_tilt_tol_deg: 3.0   # cylinder markers on `obstacles`

A field that is also a parameter of the node (amp_ls.lr, closed_loop.rate_hz, ...) is refused here: set the
parameter. Every error names the file and the field.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import yaml

from latent_planner_ros.planning.closed_loop import ClosedLoopConfig

SECTIONS = ("amp_ls", "lspp", "closed_loop")


@dataclass(frozen=True)
class PlannerTuning:
    """The contents of a tuning file (all empty: every default)."""

    amp_ls: dict = field(default_factory=dict)
    """AmpLsConfig overrides of the AMP-LS planners (amp_ls.config.with_overrides)"""
    lspp: dict = field(default_factory=dict)
    """AmpLsConfig overrides of the LSPP planner"""
    closed_loop: dict = field(default_factory=dict)
    """ClosedLoopConfig fields of both closed loops"""
    obstacle_tilt_tol_deg: float = 2.0
    """[deg] largest tilt of a cylinder marker's axis from the vertical; more is refused"""
    obstacle_z_tol_m: float = 0.01
    """[m] largest difference between a cylinder marker's pose.position.z and scale.z / 2 (standing on z = 0)"""

    def __post_init__(self) -> None:
        for name, high in (("obstacle_tilt_tol_deg", 45.0), ("obstacle_z_tol_m", 1.0)):
            v = getattr(self, name)
            if not (isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v) and 0 <= v <= high):
                raise ValueError(f"{name} must be a number in [0, {high}], got {v!r}")
        for name in SECTIONS:
            if not isinstance(getattr(self, name), dict):
                raise ValueError(f"{name} must be a mapping of fields to values, got {getattr(self, name)!r}")
        unknown = set(self.closed_loop) - set(ClosedLoopConfig.__dataclass_fields__)
        if unknown:
            raise ValueError(f"closed_loop: unknown ClosedLoopConfig field(s) {sorted(unknown)}")


def load_tuning(path: str) -> PlannerTuning:
    """The tuning file at `path` ("" = no file: every default); ValueError naming the file and the problem."""
    if not path:
        return PlannerTuning()
    try:
        data = yaml.safe_load(Path(path).read_text())
    except (OSError, yaml.YAMLError) as err:
        raise ValueError(f"tuning_file {path!r}: {err}") from None
    if data is None:
        data = {}
    if not isinstance(data, dict):
        raise ValueError(f"tuning_file {path!r}: expected a mapping of sections, got {type(data).__name__}")
    unknown = set(data) - set(PlannerTuning.__dataclass_fields__)
    if unknown:
        known = ", ".join(PlannerTuning.__dataclass_fields__)
        raise ValueError(f"tuning_file {path!r}: unknown key(s) {sorted(unknown)}; expected {known}")
    try:
        return PlannerTuning(**{k: {} if v is None and k in SECTIONS else v for k, v in data.items()})
    except ValueError as err:
        raise ValueError(f"tuning_file {path!r}: {err}") from None

"""The node suite as process specs: command lines, parameter files and environment. No ROS here.

A node ``<name>`` of ``registry.NODES`` runs as::

    <python> -m latent_planner_ros run <name> --ros-args --params-file <config>/<name>.yaml \
        -p use_sim_time:=true [-p key:=value ...] [other ROS arguments, e.g. -r goal_pose:=target_pose]

where ``<config>`` is the first directory of :func:`config_dirs` that holds ``<name>.yaml`` (no params
file if none does). Every process gets the same ``ROS_DOMAIN_ID`` (the environment's unless given).
"""

from __future__ import annotations

import os
import sys
from collections.abc import Mapping, Sequence
from pathlib import Path

from latent_planner_ros.processes.supervisor import ProcessSpec
from latent_planner_ros.registry import NODES
from latent_planner_ros.resources import resource_dirs

PACKAGE = "latent_planner_ros"

DEFAULT_NODES = ("sim", "scene_encoder", "planner")
"""The nodes of the closed-loop suite, in start order."""

LAUNCH_ENV = "LATENT_PLANNER_LAUNCH"
"""Set in every process of a suite to the launcher's pid (lets tools find the suite's processes)."""


class SuiteError(ValueError):
    """A suite that cannot be built (unknown node, bad parameter), with a message for the user."""


def config_dirs() -> list[Path]:
    """Directories searched for ``<node>.yaml``, first match wins.

    ``$LATENT_PLANNER_CONFIG`` (os.pathsep-separated), then the source tree's ``config`` (editable installs)
    and an install's ``share/latent_planner_ros/config`` (ament index, install prefix, ``sys.prefix``), as
    :func:`latent_planner_ros.resources.resource_dirs` lists them.
    """
    dirs = [Path(p) for p in os.environ.get("LATENT_PLANNER_CONFIG", "").split(os.pathsep) if p]
    return list(dict.fromkeys([*dirs, *resource_dirs("config")]))


def find_params_file(node: str) -> Path | None:
    """The first ``<node>.yaml`` in :func:`config_dirs`, or None."""
    for d in config_dirs():
        candidate = d / f"{node}.yaml"
        if candidate.is_file():
            return candidate
    return None


def parse_param(text: str) -> tuple[str, str]:
    """``"sim:real_time_factor:=0"`` -> ``("sim", "real_time_factor:=0")`` (the node and its ``-p`` argument)."""
    node, sep, assignment = text.partition(":")
    name, eq, value = assignment.partition(":=")
    if not sep or not eq or not node or not name:
        raise SuiteError(f"parameter {text!r}: expected NODE:NAME:=VALUE, e.g. sim:real_time_factor:=0")
    if node not in NODES:
        raise SuiteError(f"parameter {text!r}: unknown node {node!r}; choose one of: {', '.join(sorted(NODES))}")
    return node, f"{name}:={value}"


def node_argv(
    node: str,
    params: Sequence[str] = (),
    params_file: Path | None = None,
    use_sim_time: bool = True,
    python: str = sys.executable,
    ros_args: Sequence[str] = (),
) -> tuple[str, ...]:
    """The command line that runs `node` with a params file, ``-p`` arguments (``name:=value``) and further
    ROS arguments (`ros_args`, e.g. ``("-r", "goal_pose:=target_pose")``, appended as given)."""
    if node not in NODES:
        raise SuiteError(f"unknown node {node!r}; choose one of: {', '.join(sorted(NODES))}")
    argv = [python, "-m", PACKAGE, "run", node, "--ros-args"]
    if params_file is not None:
        argv += ["--params-file", str(params_file)]
    if use_sim_time:
        argv += ["-p", "use_sim_time:=true"]
    for p in params:
        argv += ["-p", p]
    argv += list(ros_args)
    return tuple(argv)


def suite_env(domain_id: int | None = None, headless: bool = False, base: Mapping[str, str] | None = None) -> dict:
    """The environment of every process: `base` (default os.environ) with the suite's settings.

    Args:
        domain_id: ROS_DOMAIN_ID for all processes; None keeps the environment's.
        headless: render offscreen with ``MUJOCO_GL=osmesa`` unless MUJOCO_GL is set already.
    """
    env = dict(os.environ if base is None else base)
    if domain_id is not None:
        env["ROS_DOMAIN_ID"] = str(domain_id)
    if headless:
        env.setdefault("MUJOCO_GL", "osmesa")
    env["PYTHONUNBUFFERED"] = "1"  # lines reach the launcher as they are written
    env[LAUNCH_ENV] = str(os.getpid())
    return env


def suite_specs(
    nodes: Sequence[str],
    params: Mapping[str, Sequence[str]] | None = None,
    env: Mapping[str, str] | None = None,
    use_sim_time: bool = True,
    ros_args: Mapping[str, Sequence[str]] | None = None,
) -> list[ProcessSpec]:
    """One ProcessSpec per node, each with its params file (if one exists) and extra ``-p`` arguments.

    Args:
        nodes: names in registry.NODES, in start order.
        params: node -> ``name:=value`` arguments (after the params file, so they win).
        env: the environment of every process (see :func:`suite_env`).
        ros_args: node -> further ROS arguments, e.g. ``{"planner": ("-r", "goal_pose:=target_pose")}``.
    """
    unknown = [n for n in nodes if n not in NODES]
    if unknown:
        raise SuiteError(f"unknown node {unknown[0]!r}; choose from: {', '.join(sorted(NODES))}")
    params, ros_args = params or {}, ros_args or {}
    return [
        ProcessSpec(
            name=n,
            argv=node_argv(n, params.get(n, ()), find_params_file(n), use_sim_time, ros_args=ros_args.get(n, ())),
            env=None if env is None else dict(env),
        )
        for n in nodes
    ]

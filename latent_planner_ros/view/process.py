"""The view as a process of a suite (``launch --view``, ``demo --view``). No ROS here."""

from __future__ import annotations

import sys
from collections.abc import Mapping

from latent_planner_ros.processes.supervisor import ProcessSpec

DEFAULT_PORT = 8080
"""The view's default HTTP port on localhost."""


def view_spec(
    port: int = DEFAULT_PORT, env: Mapping[str, str] | None = None, python: str = sys.executable
) -> ProcessSpec:
    """The process ``python -m latent_planner_ros view --port PORT`` (node name ``view``)."""
    argv = (python, "-m", "latent_planner_ros", "view", "--port", str(int(port)))
    return ProcessSpec(name="view", argv=argv, env=None if env is None else dict(env))


def view_url(port: int = DEFAULT_PORT) -> str:
    return f"http://localhost:{int(port)}"

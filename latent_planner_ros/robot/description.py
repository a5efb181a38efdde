"""Locate the Franka Panda description shipped by the example-robot-data package.

example-robot-data 6 installs URDF/SRDF/meshes under ``<site-packages>/cmeel.prefix/share`` and has no
Python module, so we search the interpreter's site directories for it.
"""

from __future__ import annotations

import site
import sys
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path


@dataclass(frozen=True)
class PandaDescription:
    """Paths of the Panda description files.

    Attributes:
        package_root: directory to pass as ``package_dirs`` (resolves ``package://example-robot-data/...``).
        urdf: the Panda URDF (visual .dae meshes, collision .stl meshes and finger primitives).
        srdf: the SRDF with the disabled self-collision pairs.
        mesh_dir: ``meshes/`` with ``visual/`` and ``collision/``.
    """

    package_root: Path
    urdf: Path
    srdf: Path
    mesh_dir: Path


def _candidate_roots() -> list[Path]:
    dirs = list(site.getsitepackages()) + [site.getusersitepackages()] + list(sys.path)
    roots = []
    for d in dirs:
        p = Path(d) / "cmeel.prefix" / "share"
        if p not in roots:
            roots.append(p)
    return roots


@lru_cache(maxsize=1)
def panda_description() -> PandaDescription:
    """Find the Panda description; raises FileNotFoundError naming where it looked."""
    tried = []
    for root in _candidate_roots():
        base = root / "example-robot-data" / "robots" / "panda_description"
        tried.append(str(base))
        urdf = base / "urdf" / "panda.urdf"
        if urdf.is_file():
            return PandaDescription(
                package_root=root,
                urdf=urdf,
                srdf=base / "srdf" / "panda.srdf",
                mesh_dir=base / "meshes",
            )
    raise FileNotFoundError(
        "Panda URDF not found: install example-robot-data (pip install example-robot-data); looked in "
        + ", ".join(tried)
    )

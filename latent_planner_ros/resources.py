"""Where the package's shipped files are: checkpoints, benchmark scenario sets, node configs, sim scenarios.

A checkout keeps them in the source tree (``latent_planner_ros/checkpoints``, ``latent_planner_ros/bench/scenarios``,
``config``, ``config/scenarios``), and so does an install that runs from it (``pip install -e``, ``colcon build
--symlink-install``). An installed package has them under ``share/latent_planner_ros/<the same name>``, where
setup.py's ``data_files`` puts them (``share/latent_planner_ros/checkpoints``, ``.../bench/scenarios``, ``.../config``
and ``.../config/scenarios``), found through the ament index as ROS tools find a package's share directory.

The copy next to the code wins, so a checkout never reads the weights of some other install that a sourced
workspace happens to register; an install has none there and reads its share directory. No ROS here:
``ament_index_python`` is a plain Python package, imported only when a lookup needs it.
"""

from __future__ import annotations

import sys
from pathlib import Path

PACKAGE = "latent_planner_ros"

PACKAGE_DIR = Path(__file__).resolve().parent
"""The Python package's directory (in a checkout: <repository>/latent_planner_ros)."""

SOURCE_DIRS: dict[str, Path] = {
    "checkpoints": PACKAGE_DIR / "checkpoints",
    "bench/scenarios": PACKAGE_DIR / "bench" / "scenarios",
    "config": PACKAGE_DIR.parent / "config",
    "config/scenarios": PACKAGE_DIR.parent / "config" / "scenarios",
}
"""Shipped directory, named by its path under share/latent_planner_ros -> where a checkout keeps it."""

PREFIX_DEPTH = 5
"""Ancestors of PACKAGE_DIR tried as install prefixes (<prefix>/lib/pythonX.Y/site-packages/<package> is 4 up)."""


def ament_share_dir() -> Path | None:
    """share/latent_planner_ros of the package's prefix in the ament index, or None.

    None when ament_index_python is not importable, ``$AMENT_PREFIX_PATH`` is unset, or no prefix on it
    registers the package (share/ament_index/resource_index/packages/latent_planner_ros).
    """
    try:
        from ament_index_python.packages import get_package_share_directory

        return Path(get_package_share_directory(PACKAGE))
    except (ImportError, LookupError, OSError, ValueError):
        return None


def share_dirs() -> list[Path]:
    """Candidate share/latent_planner_ros directories of installs, first preferred.

    The ament index's (a sourced colcon workspace or ROS install), then the prefix this module is installed in
    (colcon's install/latent_planner_ros run without sourcing it, pip into a venv or any ``--prefix``), then
    ``sys.prefix``'s. Directories that do not exist are listed too.
    """
    share = Path("share") / PACKAGE
    dirs = [d for d in (ament_share_dir(),) if d is not None]
    dirs += [ancestor / share for ancestor in list(PACKAGE_DIR.parents)[:PREFIX_DEPTH]]
    dirs.append(Path(sys.prefix) / share)
    return list(dict.fromkeys(dirs))


def resource_dirs(name: str) -> list[Path]:
    """Directories that may hold the shipped directory `name` (a key of SOURCE_DIRS), first preferred.

    The source tree's (a checkout, ``pip install -e``, ``colcon build --symlink-install``), then each of
    :func:`share_dirs` joined with `name`. Raises KeyError for an unknown name.
    """
    return list(dict.fromkeys([SOURCE_DIRS[name], *(d / name for d in share_dirs())]))


def find_resource(name: str, filename: str) -> Path:
    """The first ``<dir>/<filename>`` that is a file, over :func:`resource_dirs` of `name`.

    When no directory holds it, the source tree's path, so that an error about the missing file names the
    place a checkout keeps it.
    """
    dirs = resource_dirs(name)
    for d in dirs:
        if (d / filename).is_file():
            return d / filename
    return dirs[0] / filename


def shipped_checkpoint(stem: str) -> Path:
    """Path stem (no suffix) of a shipped checkpoint: the first checkpoints directory with ``<stem>.safetensors``."""
    return find_resource("checkpoints", f"{stem}.safetensors").with_suffix("")

"""sim_bridge: the MuJoCo world of the project (Panda on a table, scene objects, depth camera) and its node.

The core (``scenario``, ``mjcf``, ``sim``, ``camera``, ...) imports no rclpy; only ``sim_bridge.node`` does.

Rendering (the depth camera and pictures) needs an OpenGL context. MuJoCo picks its backend from
``MUJOCO_GL`` when ``mujoco`` is first imported; without a display we default it to ``osmesa``
(software rendering, Debian package libosmesa6) so the package works headless. Set ``MUJOCO_GL=egl``
(GPU) or ``glfw`` (a display) before importing to choose otherwise.
"""

import os as _os

if "MUJOCO_GL" not in _os.environ and not _os.environ.get("DISPLAY") and not _os.environ.get("WAYLAND_DISPLAY"):
    _os.environ["MUJOCO_GL"] = "osmesa"

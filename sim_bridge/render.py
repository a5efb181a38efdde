"""Offscreen RGB pictures of the simulation (MuJoCo's OpenGL renderer; osmesa when headless).

:class:`Recorder` writes a GIF (``out.gif``) or numbered PNG frames (any other path: a directory).
"""

from __future__ import annotations

import atexit
import weakref
from pathlib import Path

import mujoco
import numpy as np

from sim_bridge.mjcf import TARGET_SITE_GROUP

_OPEN: weakref.WeakSet = weakref.WeakSet()
_GL_HELP = (
    "headless machines need MUJOCO_GL=osmesa (apt-get install libosmesa6) or MUJOCO_GL=egl, "
    "set before mujoco is first imported"
)


def track_for_exit(renderer) -> None:
    """Close `renderer` (anything with close()) at interpreter exit if it is still open then.

    A renderer left to the garbage collector at exit fails noisily inside its OpenGL library.
    """
    _OPEN.add(renderer)


@atexit.register
def _close_open_renderers() -> None:
    for renderer in list(_OPEN):
        renderer.close()


def make_gl_context(width: int, height: int):
    """An offscreen OpenGL context of MuJoCo's configured backend; RuntimeError explaining the setup if none."""
    try:
        return mujoco.GLContext(width, height)
    except Exception as err:  # the backends raise assorted types (AttributeError, ImportError, GLError)
        raise RuntimeError(f"cannot create an offscreen OpenGL context ({err}); {_GL_HELP}") from err


def make_renderer(model: mujoco.MjModel, width: int, height: int) -> mujoco.Renderer:
    """A mujoco.Renderer; RuntimeError explaining the OpenGL setup if no context can be made."""
    try:
        renderer = mujoco.Renderer(model, height=height, width=width)
    except Exception as err:  # the backends raise assorted types (ImportError, RuntimeError, GLError)
        raise RuntimeError(f"cannot create an offscreen OpenGL context ({err}); {_GL_HELP}") from err
    track_for_exit(renderer)
    return renderer


def picture_option() -> mujoco.MjvOption:
    """Render options for pictures: the default ones plus the target marker."""
    option = mujoco.MjvOption()
    option.sitegroup[TARGET_SITE_GROUP] = 1
    return option


class Snapshotter:
    """RGB images (H, W, 3) uint8 of a named camera. Create and use it in one thread."""

    def __init__(self, model: mujoco.MjModel, camera: str, width: int = 480, height: int = 360):
        self.model = model
        try:
            self.camera_id = model.camera(camera).id
        except KeyError:
            names = [model.camera(i).name for i in range(model.ncam)]
            raise KeyError(f"no camera {camera!r} in the scene (cameras: {names})") from None
        self._renderer = make_renderer(model, width, height)
        self._option = picture_option()

    def render(self, data: mujoco.MjData) -> np.ndarray:
        """The current view (H, W, 3) uint8."""
        self._renderer.update_scene(data, camera=self.camera_id, scene_option=self._option)
        return self._renderer.render().copy()

    def close(self) -> None:
        self._renderer.close()


class Recorder:
    """Collects frames into a GIF (path ending in .gif) or writes them as PNGs into a directory.

    Args:
        path: ``*.gif``, or a directory for ``frame_00000.png, ...``.
        fps: playback rate of the GIF [frames/s].
    """

    def __init__(self, path: str | Path, fps: float = 10.0):
        self.path = Path(path)
        self.fps = float(fps)
        self.count = 0
        self._gif_frames: list[np.ndarray] | None = [] if self.path.suffix.lower() == ".gif" else None
        if self._gif_frames is None:
            self.path.mkdir(parents=True, exist_ok=True)
        else:
            self.path.parent.mkdir(parents=True, exist_ok=True)

    def add(self, frame: np.ndarray) -> None:
        """Append one RGB frame (H, W, 3) uint8."""
        import imageio.v3 as iio

        if self._gif_frames is not None:
            self._gif_frames.append(np.asarray(frame))
        else:
            iio.imwrite(self.path / f"frame_{self.count:05d}.png", frame)
        self.count += 1

    def close(self) -> Path:
        """Write the GIF (if any); returns the output path."""
        import imageio.v3 as iio

        if self._gif_frames:
            iio.imwrite(self.path, np.stack(self._gif_frames), duration=1000.0 / self.fps, loop=0)
            self._gif_frames = []
        return self.path

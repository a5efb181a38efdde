"""Depth and geom segmentation of a camera in ONE offscreen render pass.

``mujoco.Renderer`` needs two passes (its depth mode and its segmentation mode each read one buffer of
the same segmentation-coloured render); reading both buffers of a single pass halves the cost of the
simulated depth camera, which dominates the simulator's time with software (osmesa) rendering.
The depth conversion (reversed-Z buffer -> metric depth) is the one ``mujoco.Renderer`` uses.
"""

from __future__ import annotations

import mujoco
import numpy as np

from sim_bridge.render import make_gl_context, track_for_exit

_GEOM = int(mujoco.mjtObj.mjOBJ_GEOM)


class DepthSegRenderer:
    """Renders depth [m] (H, W) and the geom id (H, W) seen by one fixed camera of a model.

    Create, use and close it in one thread (it owns an OpenGL context).

    Args:
        model: the compiled model (its offscreen buffer must be at least width x height).
        camera_id: the camera to render.
        width, height: [pixels].
        option: visualisation options (which geom groups are seen).
    """

    def __init__(self, model: mujoco.MjModel, camera_id: int, width: int, height: int, option: mujoco.MjvOption):
        self.model = model
        self.width, self.height = width, height
        self._option = option
        self._camera = mujoco.MjvCamera()
        self._camera.type = mujoco.mjtCamera.mjCAMERA_FIXED
        self._camera.fixedcamid = camera_id
        self._gl = make_gl_context(width, height)
        self._gl.make_current()
        self._context = mujoco.MjrContext(model, mujoco.mjtFontScale.mjFONTSCALE_100)
        mujoco.mjr_setBuffer(mujoco.mjtFramebuffer.mjFB_OFFSCREEN, self._context)
        self._context.readDepthMap = mujoco.mjtDepthMap.mjDEPTH_ZEROFAR
        self._scene = mujoco.MjvScene(model, maxgeom=max(1000, 2 * model.ngeom))
        self._scene.flags[mujoco.mjtRndFlag.mjRND_SEGMENT] = True
        self._scene.flags[mujoco.mjtRndFlag.mjRND_IDCOLOR] = True
        self._rect = mujoco.MjrRect(0, 0, width, height)
        self._rgb = np.empty((height, width, 3), dtype=np.uint8)
        self._depth = np.empty((height, width), dtype=np.float32)
        extent = model.stat.extent
        far, near = np.float32(model.vis.map.zfar * extent), np.float32(model.vis.map.znear * extent)
        c = -(far + near) / (far - near)
        d = -(np.float32(2) * far * near) / (far - near)
        self._c, self._d = float(np.float32(-0.5) * c - np.float32(0.5)), float(np.float32(-0.5) * d)
        track_for_exit(self)

    def render(self, data: mujoco.MjData) -> tuple[np.ndarray, np.ndarray]:
        """Depth (H, W) float64 [m] along the optical axis and geom id (H, W) int32 (-1: no geom)."""
        if self._context is None:
            raise RuntimeError("render called after close")
        mujoco.mjv_updateScene(
            self.model, data, self._option, None, self._camera, mujoco.mjtCatBit.mjCAT_ALL, self._scene
        )
        self._gl.make_current()
        mujoco.mjr_render(self._rect, self._scene, self._context)
        mujoco.mjr_readPixels(self._rgb, self._depth, self._rect, self._context)
        depth = self._d / (np.flipud(self._depth).astype(np.float64) + self._c)
        rgb = np.flipud(self._rgb).astype(np.int64)
        segid = rgb[..., 0] + (rgb[..., 1] << 8) + (rgb[..., 2] << 16)  # 0 = background, else 1 + scene geom
        lookup = np.full(self._scene.ngeom + 1, -1, dtype=np.int32)
        for i in range(self._scene.ngeom):
            g = self._scene.geoms[i]
            if g.segid >= 0 and g.objtype == _GEOM:
                lookup[g.segid + 1] = g.objid
        return depth, lookup[np.minimum(segid, self._scene.ngeom)]

    def close(self) -> None:
        """Free the OpenGL resources (idempotent)."""
        if self._context is not None:
            self._gl.make_current()
            self._context.free()
            self._context = None
            self._gl.free()

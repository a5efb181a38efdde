"""The one-pass depth + segmentation renderer against mujoco.Renderer's two passes (the reference)."""

from __future__ import annotations

import mujoco
import numpy as np

from sim_bridge.camera import depth_scene_option
from sim_bridge.depth_render import DepthSegRenderer
from sim_bridge.mjcf import DEPTH_CAMERA, build_scene
from sim_bridge.render import make_renderer
from sim_bridge.scenario_files import load_scenario


def test_one_pass_matches_the_two_pass_reference():
    model = build_scene(load_scenario("tabletop", seed=2)).model
    data = mujoco.MjData(model)
    data.qpos[:7] = [0.3, 0.2, 0.0, -2.0, 0.0, 2.0, 0.8]
    mujoco.mj_forward(model, data)
    camera = model.camera(DEPTH_CAMERA).id
    option = depth_scene_option()

    fast = DepthSegRenderer(model, camera, 160, 120, option)
    depth, geom = fast.render(data)
    fast.close()

    reference = make_renderer(model, 160, 120)
    reference.enable_depth_rendering()
    reference.update_scene(data, camera=camera, scene_option=option)
    ref_depth = reference.render()
    reference.enable_segmentation_rendering()
    reference.update_scene(data, camera=camera, scene_option=option)
    seg = reference.render()
    reference.close()
    ref_geom = np.where(seg[..., 1] == int(mujoco.mjtObj.mjOBJ_GEOM), seg[..., 0], -1)

    np.testing.assert_array_equal(geom, ref_geom)
    seen = geom >= 0
    assert seen.mean() > 0.5 and len(np.unique(geom[seen])) > 5
    np.testing.assert_allclose(depth[seen], ref_depth[seen], rtol=1e-6)

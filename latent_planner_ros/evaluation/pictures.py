"""Pictures of a trial rendered afterwards from its logged joint states (MuJoCo offscreen; osmesa headless).

Rendering after the run keeps it off the simulator's loop: the scene is rebuilt from the scenario and every
frame places the arm at a logged configuration and the moving objects where the scenario had them then.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from latent_planner_ros.evaluation.trial import Tracking

VIEW = {"lookat": (0.42, 0.0, 0.22), "distance": 1.75, "azimuth": 205.0, "elevation": -28.0}
"""Free camera framing the arm and the conveyor belt (MuJoCo MjvCamera fields; angles in degrees)."""


def render_frames(scenario, q: np.ndarray, scenario_times: np.ndarray, width: int = 320, height: int = 240):
    """RGB images (F, H, W, 3) uint8 of the scenario with the arm at q (F, 7) [rad] and the moving objects
    at scenario_times (F,) [s]."""
    import mujoco

    from sim_bridge.mjcf import build_scene
    from sim_bridge.render import make_renderer, picture_option

    scene = build_scene(scenario)
    data = mujoco.MjData(scene.model)
    camera = mujoco.MjvCamera()
    camera.type = mujoco.mjtCamera.mjCAMERA_FREE
    camera.lookat[:] = VIEW["lookat"]
    camera.distance, camera.azimuth, camera.elevation = VIEW["distance"], VIEW["azimuth"], VIEW["elevation"]
    renderer = make_renderer(scene.model, width, height)
    option = picture_option()
    frames = []
    try:
        for qi, ti in zip(q, scenario_times, strict=True):
            data.qpos[:7] = qi
            for obj, mocap_id in scene.moving:
                data.mocap_pos[mocap_id] = obj.position_at(float(ti))
            mujoco.mj_forward(scene.model, data)
            renderer.update_scene(data, camera=camera, scene_option=option)
            frames.append(renderer.render().copy())
    finally:
        renderer.close()
    return np.stack(frames) if frames else np.zeros((0, height, width, 3), dtype=np.uint8)


def render_strip(
    scenario,
    tr: Tracking,
    scenario_start_s: float,
    path: str | Path,
    frames: int = 6,
    size: tuple[int, int] = (320, 240),
) -> Path:
    """A PNG strip of `frames` pictures evenly spread over the trial, each titled with time and error.

    Args:
        scenario: the sim's scenario (``sim_bridge.scenario.Scenario``) the trial ran in.
        tr: the trial's tracking (times [s], joint positions, errors).
        scenario_start_s: trial time at which the scenario started (object positions = scenario time).
        path: the PNG to write.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    if len(tr.t) == 0:
        raise ValueError("no joint states with a known target: nothing to render")
    idx = np.unique(np.searchsorted(tr.t, np.linspace(tr.t[0], tr.t[-1], frames)).clip(0, len(tr.t) - 1))
    images = render_frames(scenario, tr.q[idx], tr.t[idx] - scenario_start_s, *size)
    cols = len(idx)
    fig, axes = plt.subplots(1, cols, figsize=(2.6 * cols, 2.6 * size[1] / size[0] + 0.4), squeeze=False)
    for ax, image, k in zip(axes[0], images, idx, strict=True):
        ax.imshow(image)
        ax.set_title(f"t = {tr.t[k]:.1f} s, error {100 * tr.pos_err_m[k]:.1f} cm", fontsize=8)
        ax.axis("off")
    fig.tight_layout()
    fig.savefig(path, dpi=110, bbox_inches="tight")
    plt.close(fig)
    return path

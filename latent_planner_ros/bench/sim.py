"""`bench sim`: simulator speed (physics + depth camera at the default settings), cloud sizes, and how well
10 Hz joint targets are tracked. Writes DIR/sim.json, DIR/sim.md and PNGs (camera views, cloud, tracking)."""

from __future__ import annotations

import os
import time
from dataclasses import replace

import matplotlib.pyplot as plt
import numpy as np

from latent_planner_ros.bench.report import bench_parser, write_report
from latent_planner_ros.robot.limits import Q_MAX, Q_MIN, Q_READY, V_MAX
from latent_planner_ros.robot.panda import load_panda
from sim_bridge.mjcf import DEPTH_CAMERA, OVERVIEW_CAMERA
from sim_bridge.render import Snapshotter
from sim_bridge.runner import Runner
from sim_bridge.scenario import Scenario
from sim_bridge.scenario_files import load_scenario
from sim_bridge.sim import Sim
from sim_bridge.sim_config import SimConfig

COMMAND_STEPS = 50  # physics steps per 10 Hz command at the default 2 ms


def measure_speed(scenario: Scenario, seconds: float, rng: np.random.Generator) -> dict:
    """Run flat out for `seconds` of simulated time with a random walk of 10 Hz commands.

    Returns the real-time factor with the camera at its rate (wall clock, and CPU time of this process, which
    other load on the machine does not change), without the camera (physics only), the time per cloud [ms]
    and the cloud sizes.
    """
    sim = Sim(scenario, replace(SimConfig(), real_time_factor=0.0))
    runner = Runner(sim)
    runner.advance()  # one-off: OpenGL context
    q = np.array(Q_READY)
    sizes, cloud_s = [], []
    start, cpu_start = time.perf_counter(), time.process_time()
    physics_s = 0.0
    ticks = round(seconds * sim.config.joint_state_rate)
    for k in range(ticks):
        if k % 10 == 0:  # 10 Hz at 100 ticks/s
            q = np.clip(q + rng.normal(0.0, 0.05, size=7), Q_MIN + 0.1, Q_MAX - 0.1)
            sim.set_command(q)
        t0 = time.perf_counter()
        tick = runner.advance()
        physics_s += time.perf_counter() - t0
        sim.get_state()
        if tick.cloud_due:
            t0 = time.perf_counter()
            sizes.append(len(sim.point_cloud()))
            sim.target_pose()
            cloud_s.append(time.perf_counter() - t0)
    wall, cpu = time.perf_counter() - start, time.process_time() - cpu_start
    sim.close()
    return {
        "real_time_factor": seconds / wall,
        "cpu_real_time_factor": seconds / cpu,
        "physics_real_time_factor": seconds / physics_s,
        "cloud_ms_median": 1000 * float(np.median(cloud_s)),
        "cloud_sizes": sizes,
    }


def measure_tracking(paths: int, rng: np.random.Generator) -> dict:
    """Stream 2 s paths at 10 Hz from the ready pose, then hold 0.5 s; end-effector error after the hold.

    Returns the errors [mm], the peak joint speed as a fraction of V_MAX, the worst overshoot [rad] and
    the traces of the first path for plotting.
    """
    panda = load_panda()
    sim = Sim(Scenario(name="empty"))
    errors, speed, overshoot, trace = [], 0.0, 0.0, None
    for i in range(paths):
        sim.reset()
        goal = np.clip(Q_READY + rng.uniform(-0.8, 0.8, size=7), Q_MIN + 0.1, Q_MAX - 0.1)
        s = np.linspace(0, 1, 21)[1:]
        path = Q_READY + (0.5 - 0.5 * np.cos(np.pi * s))[:, None] * (goal - Q_READY)
        t, qs, cmd = [], [], []
        for target in [*path, None]:
            if target is not None:
                sim.set_command(target)
            for _ in range(COMMAND_STEPS if target is not None else 250):
                sim.step()
                t.append(sim.data.time)
                qs.append(sim.data.qpos[:7].copy())
                cmd.append(path[-1] if target is None else target)
                speed = max(speed, float(np.max(np.abs(sim.data.qvel[:7]) / V_MAX)))
        qs = np.array(qs)
        hold = qs[len(path) * COMMAND_STEPS :] - goal
        overshoot = max(overshoot, float(np.max(np.clip(-hold * np.sign(hold[0]), 0.0, None))))
        errors.append(1000 * np.linalg.norm(sim.get_state().tcp_position - panda.fk(goal).translation))
        if i == 0:
            trace = (np.array(t), qs, np.array(cmd))
    sim.close()
    return {"errors_mm": errors, "max_speed_ratio": speed, "overshoot_rad": overshoot, "trace": trace}


def _views(scenario: Scenario) -> tuple[plt.Figure, plt.Figure, int]:
    """RGB pictures of the overview and depth cameras, and a plot of the depth camera's cloud."""
    sim = Sim(scenario)
    sim.step(50)
    pictures = []
    for camera in (OVERVIEW_CAMERA, DEPTH_CAMERA):
        snap = Snapshotter(sim.model, camera, 480, 360)
        pictures.append(snap.render(sim.data))
        snap.close()
    cloud = sim.point_cloud()
    sim.close()
    views, axes = plt.subplots(1, 2, figsize=(10, 3.9))
    for ax, image, title in zip(axes, pictures, ("overview camera", "depth camera (RGB)"), strict=True):
        ax.imshow(image)
        ax.set_title(title)
        ax.axis("off")
    fig = plt.figure(figsize=(10, 4.2))
    ax3 = fig.add_subplot(1, 2, 1, projection="3d")
    ax3.scatter(cloud[:, 0], cloud[:, 1], cloud[:, 2], s=1, c=cloud[:, 2], cmap="viridis")
    ax3.set_box_aspect((1.1, 1.4, 0.6))
    ax3.view_init(28, -25)
    ax3.set_xlabel("x [m]")
    ax3.set_ylabel("y [m]")
    ax3.set_title(f"camera/points ({len(cloud)} points, robot removed)")
    ax2 = fig.add_subplot(1, 2, 2)
    ax2.scatter(cloud[:, 1], cloud[:, 0], s=1, c=cloud[:, 2], cmap="viridis")
    ax2.set_xlabel("y [m]")
    ax2.set_ylabel("x [m]")
    ax2.invert_xaxis()
    ax2.set_aspect("equal")
    ax2.set_title("top view, colour = height")
    return views, fig, len(cloud)


def _tracking_figure(trace) -> plt.Figure:
    t, qs, cmd = trace
    fig, ax = plt.subplots(figsize=(8, 3.6))
    for j in range(7):
        (line,) = ax.plot(t, qs[:, j], lw=1.5, label=f"joint {j + 1}")
        ax.step(t, cmd[:, j], where="post", color=line.get_color(), lw=0.8, ls="--")
    ax.axvline(2.0, color="grey", lw=0.8)
    ax.set_xlabel("simulated time [s]")
    ax.set_ylabel("q [rad]")
    ax.set_title("10 Hz targets (dashed) and joint positions; commands stop at 2 s")
    ax.legend(ncol=4, fontsize=7)
    return fig


def main(argv: list[str]) -> int:
    p = bench_parser("sim", __doc__)
    p.add_argument("--seconds", type=float, default=10.0, help="simulated seconds per scenario for the speed test")
    p.add_argument("--scenarios", nargs="+", default=["tabletop", "conveyor"], help="scenarios of the speed test")
    p.add_argument("--paths", type=int, default=10, help="tracking test paths")
    args = p.parse_args(argv)
    rng = np.random.default_rng(0)
    load = ", ".join(f"{x:.1f}" for x in os.getloadavg())

    speed = {name: measure_speed(load_scenario(name, seed=0), args.seconds, rng) for name in args.scenarios}
    tracking = measure_tracking(args.paths, rng)
    views, cloud_fig, _ = _views(load_scenario(args.scenarios[0], seed=0))
    sizes = np.concatenate([s["cloud_sizes"] for s in speed.values()])
    config = SimConfig()
    errors = np.array(tracking["errors_mm"])
    first = speed[args.scenarios[0]]
    results = {
        "real_time_factor": first["real_time_factor"],
        "cpu_real_time_factor": first["cpu_real_time_factor"],
        "physics_real_time_factor": first["physics_real_time_factor"],
        "cloud_ms_median": first["cloud_ms_median"],
        "cloud_points_median": float(np.median(sizes)),
        "cloud_points_min": int(sizes.min()),
        "cloud_points_max": int(sizes.max()),
        "per_scenario": {
            name: {k: v for k, v in s.items() if k != "cloud_sizes"}
            | {"cloud_points_median": float(np.median(s["cloud_sizes"]))}
            for name, s in speed.items()
        },
        "tracking_error_mm_max": float(errors.max()),
        "tracking_error_mm_median": float(np.median(errors)),
        "tracking_max_speed_ratio": tracking["max_speed_ratio"],
        "tracking_overshoot_rad": tracking["overshoot_rad"],
        "load_average": load,
        "settings": {
            "timestep_s": config.timestep,
            "cloud_rate_hz": config.cloud_rate,
            "camera": f"{config.camera.width}x{config.camera.height}, fovy {config.camera.fovy} deg",
            "voxel_size_m": config.camera.voxel_size,
            "speed_test_seconds": args.seconds,
            "tracking_paths": args.paths,
        },
    }
    rows = "\n".join(
        f"| {name} | {s['real_time_factor']:.2f} | {s['cpu_real_time_factor']:.2f} | "
        f"{s['physics_real_time_factor']:.1f} | {s['cloud_ms_median']:.1f} | {np.median(s['cloud_sizes']):.0f} |"
        for name, s in speed.items()
    )
    md = f"""# bench sim

The simulator flat out ({args.seconds:g} simulated s per scenario, 10 Hz random-walk commands) with the
default settings: {config.timestep * 1000:g} ms physics step, joint states at {config.joint_state_rate:g} Hz, a
{results["settings"]["camera"]} depth camera at {config.cloud_rate:g} Hz rendered offscreen (two passes: depth
and geom segmentation), robot removed, cropped, {config.camera.voxel_size * 100:g} cm voxel grid.
Real-time factor = simulated time / wall time for everything the node computes per second (no ROS);
"per CPU second" divides by this process's CPU time instead, which other load on the machine does not change.
Load average when the run started: {load}.

| scenario | real-time factor | per CPU second | physics only | ms per cloud | points per cloud (median) |
| --- | --- | --- | --- | --- | --- |
{rows}

Tracking: {args.paths} smooth 2 s paths (up to 0.8 rad per joint) streamed as 10 Hz targets from the ready pose,
then 0.5 s without commands.

| metric | value |
| --- | --- |
| end-effector error 0.5 s after the last target, median / max | {np.median(errors):.4f} / {errors.max():.4f} mm |
| peak joint speed | {tracking["max_speed_ratio"]:.2f} x V_MAX |
| overshoot past the final target | {tracking["overshoot_rad"] * 1000:.3f} mrad |
"""
    figures = {"views": views, "cloud": cloud_fig, "tracking": _tracking_figure(tracking["trace"])}
    write_report(args.out, "sim", results, md, figures, argv)
    return 0

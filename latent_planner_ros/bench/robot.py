"""`bench robot`: torch FK accuracy against pinocchio and the feasible-state sampler's throughput."""

from __future__ import annotations

import time

import matplotlib.pyplot as plt
import numpy as np
import pinocchio as pin
import torch

from latent_planner_ros.bench.report import bench_parser, write_report
from latent_planner_ros.robot.limits import Q_MAX, Q_MIN
from latent_planner_ros.robot.panda import LINK_FRAMES, load_panda
from latent_planner_ros.robot.sampler import FeasibleSampler
from latent_planner_ros.robot.torch_fk import TorchFK


def fk_errors(q: np.ndarray, dtype: torch.dtype) -> tuple[np.ndarray, np.ndarray]:
    """Per-configuration max position error [m] and rotation error [rad] over all link frames."""
    panda = load_panda()
    data = panda.model.createData()
    ids = [panda.frame_id(f) for f in LINK_FRAMES]
    got = TorchFK(dtype=dtype)(torch.as_tensor(q)).double().numpy()
    pos_err = np.zeros(len(q))
    rot_err = np.zeros(len(q))
    for i, qi in enumerate(q):
        pin.framesForwardKinematics(panda.model, data, qi)
        for k, fid in enumerate(ids):
            m = data.oMf[fid]
            pos_err[i] = max(pos_err[i], np.abs(m.translation - got[i, k, :3, 3]).max())
            rel = m.rotation.T @ got[i, k, :3, :3]
            rot_err[i] = max(rot_err[i], np.linalg.norm(pin.log3(_orthonormalise(rel))))
    return pos_err, rot_err


def _orthonormalise(r: np.ndarray) -> np.ndarray:
    u, _, vt = np.linalg.svd(r)
    return u @ vt


def main(argv: list[str]) -> int:
    p = bench_parser("robot", __doc__)
    p.add_argument("--configs", type=int, default=10_000, help="random configurations for the FK check")
    p.add_argument("--sampler-states", type=int, default=20_000)
    args = p.parse_args(argv)
    rng = np.random.default_rng(0)
    q = rng.uniform(Q_MIN, Q_MAX, size=(args.configs, 7))
    pos32, rot32 = fk_errors(q, torch.float32)
    pos64, rot64 = fk_errors(q, torch.float64)

    fk = TorchFK()
    qt = torch.as_tensor(q[:1024], dtype=torch.float32)
    fk(qt)
    t0 = time.perf_counter()
    for _ in range(20):
        fk(qt)
    fk_ms = (time.perf_counter() - t0) / 20 * 1000

    sampler = FeasibleSampler(np.random.default_rng(1))
    sampler.sample(1000)
    t0 = time.perf_counter()
    sampler.sample(args.sampler_states)
    rate = args.sampler_states / (time.perf_counter() - t0)

    results = {
        "fk_max_pos_err_m": float(pos32.max()),
        "fk_max_rot_err_rad": float(rot32.max()),
        "fk_float64_max_pos_err_m": float(pos64.max()),
        "fk_float64_max_rot_err_rad": float(rot64.max()),
        "fk_configs": args.configs,
        "fk_batch1024_ms": fk_ms,
        "sampler_states_per_s": rate,
        "torch_threads": torch.get_num_threads(),
    }
    md = f"""# bench robot

Torch FK (float32, all {len(LINK_FRAMES)} link frames) against pinocchio on {args.configs} uniform configurations,
and the feasible-state sampler (uniform in limits, rejecting self and table collisions).

| metric | value |
| --- | --- |
| max position error, float32 | {pos32.max():.2e} m |
| max rotation error, float32 | {rot32.max():.2e} rad |
| max position error, float64 | {pos64.max():.2e} m |
| max rotation error, float64 | {rot64.max():.2e} rad |
| FK of 1024 configurations | {fk_ms:.2f} ms |
| sampler throughput | {rate:,.0f} feasible states/s (one process) |
"""
    fig, axes = plt.subplots(1, 2, figsize=(9, 3.2))
    for ax, data, label in ((axes[0], pos32, "position error [m]"), (axes[1], rot32, "rotation error [rad]")):
        ax.hist(np.log10(np.maximum(data, 1e-12)), bins=50, color="tab:blue")
        ax.set_xlabel(f"log10 {label}")
        ax.set_ylabel("configurations")
    fig.suptitle("torch FK (float32) vs pinocchio, worst frame per configuration")
    write_report(args.out, "robot", results, md, {"fk_error": fig}, argv)
    return 0

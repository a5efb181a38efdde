"""Give a trained collision network a larger workspace box without retraining.

The scene encoder is convolutional, so its weights apply to a grid of any size; the only input that depends
on the box is the classifier's link point positions, normalised to [-1, 1] over the box. `grow_box` builds
the same network over a larger box (same voxel size, voxels aligned with the old grid) and rewrites the
classifier's first layer so that it reads the new normalisation exactly as it read the old one: inside the
old box the network computes what it did before, except near the old box's faces, where its convolutions
now see the voxels beyond them instead of zero padding.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import torch

from latent_planner_ros.models.collision_net import CollisionNet


def grow_box(net: CollisionNet, bounds_min, bounds_max) -> CollisionNet:
    """The network `net` over the box [bounds_min, bounds_max] (3,) [m] in `world`, which must contain its box
    and lie on its voxel grid. Returns a new network (eval mode); `net` is left unchanged.

    Raises ValueError if the new box is smaller or off the old grid."""
    old = net.config.encoder
    lo_o, hi_o = np.asarray(old.bounds_min, float), np.asarray(old.bounds_max, float)
    lo_n, hi_n = np.asarray(bounds_min, float), np.asarray(bounds_max, float)
    if lo_n.shape != (3,) or hi_n.shape != (3,):
        raise ValueError("bounds_min and bounds_max must have 3 components (x, y, z) [m]")
    if np.any(lo_n > lo_o + 1e-9) or np.any(hi_n < hi_o - 1e-9):
        raise ValueError(f"the new box {lo_n.tolist()}..{hi_n.tolist()} must contain the network's box "
                         f"{lo_o.tolist()}..{hi_o.tolist()}")  # fmt: skip
    shift = (lo_o - lo_n) / old.voxel_size
    if np.any(np.abs(shift - np.round(shift)) > 1e-6):
        raise ValueError(f"the new box's lower corner is not on the network's {old.voxel_size} m voxel grid")
    encoder = replace(old, bounds_min=tuple(lo_n.tolist()), bounds_max=tuple(hi_n.tolist()))  # checks whole voxels
    grown = CollisionNet(replace(net.config, encoder=encoder))
    state = {k: v.clone() for k, v in net.state_dict().items()}
    # old normalised position = a * new normalised position + b, per axis
    c_o, h_o, c_n, h_n = (lo_o + hi_o) / 2, (hi_o - lo_o) / 2, (lo_n + hi_n) / 2, (hi_n - lo_n) / 2
    a, b = h_n / h_o, (c_n - c_o) / h_o
    w, bias = state["classifier.0.weight"], state["classifier.0.bias"]
    k, channels = net.config.points_per_link, old.channels
    for j in range(k):  # the position columns follow the k * channels feature columns, (x, y, z) per point
        cols = slice(k * channels + 3 * j, k * channels + 3 * j + 3)
        bias += w[:, cols] @ torch.as_tensor(b, dtype=w.dtype)
        w[:, cols] *= torch.as_tensor(a, dtype=w.dtype)
    grown.load_state_dict(state)
    return grown.eval()

"""Signed distance from points to upright cylinders o = (x, y, h, r) standing on the table (z from 0 to h)."""

from __future__ import annotations

import numpy as np


def cylinder_distance(points: np.ndarray, cylinders: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Signed distances (P, K) [m] of points (P, 3) [m] to the solid cylinders (K, 4), and unit directions
    (P, K, 3) pointing from the nearest surface point towards the point (away from the cylinder).

    A point inside a cylinder has a negative distance (minus its depth below the side or the top, whichever is
    smaller) and the direction of that shallower way out. The bottom face rests on the table and is ignored.
    """
    p = np.asarray(points, dtype=float).reshape(-1, 1, 3)
    c = np.asarray(cylinders, dtype=float).reshape(1, -1, 4)
    dxy = p[..., :2] - c[..., :2]  # (P, K, 2)
    rho = np.linalg.norm(dxy, axis=-1)
    u = np.where(rho[..., None] > 1e-9, dxy / np.maximum(rho, 1e-9)[..., None], np.array([1.0, 0.0]))
    r, h, z = c[..., 3], c[..., 2], p[..., 2]
    nearest_xy = c[..., :2] + u * np.minimum(rho, r)[..., None]
    nearest = np.concatenate([nearest_xy, np.clip(z, 0.0, h)[..., None]], axis=-1)
    diff = p - nearest
    dist = np.linalg.norm(diff, axis=-1)
    direction = diff / np.maximum(dist, 1e-12)[..., None]

    side_depth, top_depth = r - rho, h - z
    inside = (side_depth >= 0) & (top_depth >= 0) & (z >= 0) & (dist < 1e-12)
    out_side = inside & (side_depth <= top_depth)
    out_top = inside & ~out_side
    dist = np.where(out_side, -side_depth, np.where(out_top, -top_depth, dist))
    radial = np.concatenate([u, np.zeros_like(rho)[..., None]], axis=-1)
    direction = np.where(out_side[..., None], radial, direction)
    direction = np.where(out_top[..., None], np.array([0.0, 0.0, 1.0]), direction)
    return dist, direction

"""Geometry of obstacles: coal collision objects, triangle meshes (for raycasting) and surface samples."""

from __future__ import annotations

import coal
import numpy as np

from latent_planner_ros.data.obstacles import Box, Capsule, Cylinder, Mesh, Obstacle, Sphere, pose_matrix

_SEGMENTS = 24
"""Facets around the axis of tessellated round primitives."""


def is_convex(vertices: np.ndarray, faces: np.ndarray, tol: float = 1e-6) -> bool:
    """True if every vertex (V, 3) lies on the inner side of every face plane (outward winding)."""
    tri = vertices[faces]  # (F, 3, 3)
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    n /= np.linalg.norm(n, axis=1, keepdims=True).clip(1e-12)
    d = np.einsum("fk,vk->fv", n, vertices) - np.einsum("fk,fk->f", n, tri[:, 0])[:, None]
    return bool(np.all(d <= tol * max(1.0, float(np.abs(vertices).max()))))


def coal_geometry(obstacle: Obstacle) -> tuple[coal.CollisionGeometry, coal.Transform3s]:
    """A coal geometry and its placement in `world`.

    Primitives map to coal's solid shapes. Convex meshes become a solid coal.Convex; other meshes a
    BVH of their triangles (surface only: a link fully inside such a mesh is not reported).
    """
    t = pose_matrix(obstacle)
    tf = coal.Transform3s(t[:3, :3].copy(), t[:3, 3].copy())
    if isinstance(obstacle, Box):
        return coal.Box(*(2.0 * np.asarray(obstacle.half_extents))), tf
    if isinstance(obstacle, Sphere):
        return coal.Sphere(obstacle.radius), tf
    if isinstance(obstacle, Cylinder):
        return coal.Cylinder(obstacle.radius, 2.0 * obstacle.half_length), tf
    if isinstance(obstacle, Capsule):
        return coal.Capsule(obstacle.radius, 2.0 * obstacle.half_length), tf
    if isinstance(obstacle, Mesh):
        pts = coal.StdVec_Vec3s()
        pts.extend(list(obstacle.vertices.astype(float)))
        if is_convex(obstacle.vertices, obstacle.faces):
            return coal.Convex.convexHull(pts, False, None), tf
        bvh = coal.BVHModelOBBRSS()
        bvh.beginModel(len(obstacle.faces), len(obstacle.vertices))
        bvh.addVertices(obstacle.vertices.astype(float))
        bvh.addTriangles(obstacle.faces.astype(np.int64))
        bvh.endModel()
        return bvh, tf
    raise TypeError(f"not an obstacle: {obstacle!r}")


def _unit_box() -> tuple[np.ndarray, np.ndarray]:
    v = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], dtype=float)
    f = np.array(
        [[0, 1, 3], [0, 3, 2], [4, 6, 7], [4, 7, 5], [0, 4, 5], [0, 5, 1],
         [2, 3, 7], [2, 7, 6], [0, 2, 6], [0, 6, 4], [1, 5, 7], [1, 7, 3]],
    )  # fmt: skip
    return v, f


def _lathe(profile: np.ndarray, poles: tuple[float, float], segments: int = _SEGMENTS) -> tuple[np.ndarray, np.ndarray]:
    """Surface of revolution about z of a profile (P, 2) of (radius, z), bottom to top, closed by fans to
    the points (0, 0, poles[0]) and (0, 0, poles[1])."""
    ang = np.linspace(0.0, 2 * np.pi, segments, endpoint=False)
    rings = [np.stack([r * np.cos(ang), r * np.sin(ang), np.full(segments, z)], 1) for r, z in profile]
    v = np.concatenate([*rings, [[0.0, 0.0, poles[0]], [0.0, 0.0, poles[1]]]])
    bottom, top = len(v) - 2, len(v) - 1
    faces = []
    for i in range(len(profile) - 1):
        a, b = i * segments, (i + 1) * segments
        for j in range(segments):
            k = (j + 1) % segments
            faces += [[a + j, a + k, b + k], [a + j, b + k, b + j]]
    last = (len(profile) - 1) * segments
    for j in range(segments):
        k = (j + 1) % segments
        faces += [[bottom, k, j], [top, last + j, last + k]]
    return v, np.asarray(faces)


def triangle_mesh(obstacle: Obstacle) -> tuple[np.ndarray, np.ndarray]:
    """Tessellated surface in `world`: vertices (V, 3) float64 [m], faces (F, 3) int64 (outward winding)."""
    if isinstance(obstacle, Mesh):
        return obstacle.vertices, obstacle.faces
    if isinstance(obstacle, Box):
        v, f = _unit_box()
        v = v * np.asarray(obstacle.half_extents)
    elif isinstance(obstacle, Cylinder):
        r, h = obstacle.radius, obstacle.half_length
        v, f = _lathe(np.array([[r, -h], [r, h]]), (-h, h))
    else:  # sphere or capsule: rings of latitude, the two hemispheres shifted apart by the axis segment
        r = obstacle.radius
        h = obstacle.half_length if isinstance(obstacle, Capsule) else 0.0
        lat = np.linspace(0.0, np.pi / 2, _SEGMENTS // 4 + 1)[:-1]  # equator .. below the pole
        lower = np.stack([r * np.cos(lat[::-1]), -r * np.sin(lat[::-1]) - h], 1)
        upper = np.stack([r * np.cos(lat), r * np.sin(lat) + h], 1)
        profile = np.concatenate([lower, upper[1:] if h == 0.0 else upper])
        v, f = _lathe(profile, (-r - h, r + h))
    t = pose_matrix(obstacle)
    return v @ t[:3, :3].T + t[:3, 3], f


def sample_surface(obstacle: Obstacle, n: int, rng: np.random.Generator) -> np.ndarray:
    """n points (n, 3) [m] drawn uniformly by area from the tessellated surface of the obstacle."""
    v, f = triangle_mesh(obstacle)
    tri = v[f]
    area = 0.5 * np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
    idx = rng.choice(len(f), size=n, p=area / area.sum())
    a, b = rng.random((2, n, 1))
    flip = a + b > 1
    a, b = np.where(flip, 1 - a, a), np.where(flip, 1 - b, b)
    t = tri[idx]
    return t[:, 0] + a * (t[:, 1] - t[:, 0]) + b * (t[:, 2] - t[:, 0])


def surface_area(obstacle: Obstacle) -> float:
    """Area [m^2] of the tessellated surface of the obstacle."""
    v, f = triangle_mesh(obstacle)
    tri = v[f]
    return float(0.5 * np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1).sum())

"""Small geometry helpers for the simulator: convex polygons in the plane and oriented boxes in space.

Units are whatever the caller uses (mm in the kit). Polygons are (K, 2) arrays of vertices in order (either
direction); boxes are (centre (3,), rotation (3, 3) whose columns are the box axes, half extents (3,)).
"""

from __future__ import annotations

import math

import numpy as np

from armlab.transforms import wrap_quarter

__all__ = ["polygons_overlap", "convex_hull", "separation_along", "boxes_overlap",
           "box_corners", "wrap_quarter", "prism_features", "convex_penetration"]


def _edge_normals(poly: np.ndarray) -> np.ndarray:
    edges = np.roll(poly, -1, axis=0) - poly
    return np.column_stack([-edges[:, 1], edges[:, 0]])


def polygons_overlap(a: np.ndarray, b: np.ndarray, margin: float = 0.0) -> bool:
    """True when convex polygons a (K, 2) and b (M, 2) overlap by more than `margin` along every separating axis
    (separating axis theorem); margin < 0 also counts polygons closer than |margin| as overlapping."""
    for axis in np.vstack([_edge_normals(a), _edge_normals(b)]):
        n = np.linalg.norm(axis)
        if n < 1e-12:
            continue
        pa, pb = a @ (axis / n), b @ (axis / n)
        if min(pa.max(), pb.max()) - max(pa.min(), pb.min()) <= margin:
            return False
    return True


def convex_hull(points) -> np.ndarray:
    """Convex hull (K, 2) of points (N, 2), counter-clockwise (Andrew's monotone chain)."""
    pts = sorted({(float(x), float(y)) for x, y in np.asarray(points, dtype=float)})
    if len(pts) <= 2:
        return np.array(pts)

    def half(seq):
        out: list[tuple[float, float]] = []
        for p in seq:
            while len(out) >= 2 and ((out[-1][0] - out[-2][0]) * (p[1] - out[-2][1])
                                     - (out[-1][1] - out[-2][1]) * (p[0] - out[-2][0])) <= 0:
                out.pop()
            out.append(p)
        return out

    lower, upper = half(pts), half(reversed(pts))
    return np.array(lower[:-1] + upper[:-1])


def separation_along(moving: np.ndarray, fixed: np.ndarray, direction) -> float:
    """How far polygon `moving` must travel along the unit `direction` (2,) to stop overlapping `fixed` (>= 0)."""
    d = np.asarray(direction, dtype=float)
    return max(0.0, float((fixed @ d).max() - (moving @ d).min()))


def box_corners(centre, rotation, half) -> np.ndarray:
    """The 8 corners (8, 3) of an oriented box; rotation columns are the box axes, half the half extents."""
    signs = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)], dtype=float)
    return np.asarray(centre, float) + (signs * np.asarray(half, float)) @ np.asarray(rotation, float).T


def boxes_overlap(c1, R1, h1, c2, R2, h2, margin: float = 0.0) -> bool:
    """True when two oriented boxes interpenetrate by more than `margin` (separating axis theorem, 15 axes: the
    boxes' own axes first, then the 9 cross products of theirs, built only when the own axes separate nothing)."""
    R1, R2 = np.asarray(R1, float), np.asarray(R2, float)
    d = np.asarray(c2, float) - np.asarray(c1, float)
    h1, h2 = np.asarray(h1, float), np.asarray(h2, float)
    R1t, R2t = R1.T, R2.T

    def separates(axis: np.ndarray) -> bool:
        axis = np.ascontiguousarray(axis)
        n = math.sqrt(axis.dot(axis))          # np.linalg.norm of a vector (the same dot), without its per-call cost
        if n < 1e-9:
            return False
        axis = axis / n
        r1 = np.sum(h1 * np.abs(R1t @ axis))
        r2 = np.sum(h2 * np.abs(R2t @ axis))
        return r1 + r2 - abs(d @ axis) <= margin

    if any(separates(R[:, i]) for R in (R1, R2) for i in range(3)):
        return False
    crosses = np.cross(R1t[:, None, :], R2t[None, :, :])      # (3, 3, 3): R1[:, i] x R2[:, j] at [i, j]
    return not any(separates(crosses[i, j]) for i in range(3) for j in range(3))


def prism_features(poly, half_height: float, pose) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The convex prism of footprint `poly` (K, 2) (the prism's own x, y) from z = -half_height to +half_height in its
    own frame, placed by `pose` (..., 4, 4) (prism frame -> world): its vertices (..., 2K, 3), unit face normals
    (..., K + 1, 3) and unit edge directions (..., K + 1, 3), in world units (mm in the kit), for convex_penetration.
    """
    poly = np.asarray(poly, dtype=float)
    pose = np.asarray(pose, dtype=float)
    k = len(poly)
    h = float(half_height)
    local = np.vstack([np.column_stack([poly, np.full(k, -h)]), np.column_stack([poly, np.full(k, h)])])
    edges = np.roll(poly, -1, axis=0) - poly
    edges = edges / np.linalg.norm(edges, axis=1, keepdims=True)
    up = np.array([[0.0, 0.0, 1.0]])
    normals = np.vstack([np.column_stack([edges[:, 1], -edges[:, 0], np.zeros(k)]), up])
    directions = np.vstack([np.column_stack([edges, np.zeros(k)]), up])
    R, t = pose[..., :3, :3], pose[..., :3, 3]
    turn = lambda v: np.einsum("...ij,vj->...vi", R, v)   # noqa: E731
    return turn(local) + t[..., None, :], turn(normals), turn(directions)


def convex_penetration(a, b) -> np.ndarray:
    """How deep (in the callers' units) two convex polyhedra interpenetrate, by the separating axis theorem: the least
    overlap of their projections over the face normals of both and the cross products of their edge directions.

    a, b: (vertices (..., V, 3), unit face normals (..., F, 3), unit edge directions (..., E, 3)), e.g. from
    prism_features; the leading dimensions broadcast (e.g. a moving prism sampled along a path against a fixed one).
    Returns (...,): > 0 the penetration depth (how far one must move to come apart), 0 touching, < 0 apart (then
    -value is a lower bound on their distance).
    """
    va, na, ea = (np.asarray(x, dtype=float) for x in a)
    vb, nb, eb = (np.asarray(x, dtype=float) for x in b)
    lead = np.broadcast_shapes(va.shape[:-2], na.shape[:-2], ea.shape[:-2], vb.shape[:-2], nb.shape[:-2],
                               eb.shape[:-2])
    cross = np.cross(ea[..., :, None, :], eb[..., None, :, :])
    cross = np.broadcast_to(cross, lead + cross.shape[-3:]).reshape(lead + (-1, 3))
    axes = np.concatenate([np.broadcast_to(na, lead + na.shape[-2:]), np.broadcast_to(nb, lead + nb.shape[-2:]),
                           cross], axis=-2)
    norm = np.linalg.norm(axes, axis=-1)
    valid = norm > 1e-6                                  # parallel edges give no axis
    axes = axes / np.where(valid, norm, 1.0)[..., None]
    pa = np.einsum("...vk,...mk->...mv", va, axes)
    pb = np.einsum("...vk,...mk->...mv", vb, axes)
    overlap = np.minimum(pa.max(-1), pb.max(-1)) - np.maximum(pa.min(-1), pb.min(-1))
    return np.where(valid, overlap, np.inf).min(axis=-1)

"""The planar faces the simulated camera sees: blocks and distractors (extruded footprints) and the RX200 arm (boxes).

Faces come in a `FaceSet`: arrays of convex polygons in the world frame (mm) with their outward unit normals and base
RGB colours (the colour a face lit like a block's top face shows; `shade` darkens faces turned away from the light).
Everything is built with whole-array numpy operations, not face by face: a frame holds a few hundred faces. The arm
is drawn as boxes along `armlab.kinematics.joint_positions` (links ~40 mm wide) on its base plate (the lab config's
robot_base, data/lab.json) plus the gripper housing and two fingers at the opening.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from armlab.blocks import LAB_RGB, ObjectState
from armlab.kinematics import frame_points, link_frames
from armlab.lab import lab_config
from armlab.transforms import rot_x, rot_y

__all__ = ["FaceSet", "object_faces", "objects_faces", "arm_faces", "box_faces", "shade", "LIGHT_DIR", "ARM_RGB",
           "FINGER_RGB"]

LIGHT_DIR = np.array([0.3, -0.4, 1.0]) / np.linalg.norm([0.3, -0.4, 1.0])   # towards the lab's ceiling light
AMBIENT, DIFFUSE = 0.45, 0.55
ARM_RGB = (36, 36, 38)          # the RX200's black links
FINGER_RGB = (52, 52, 54)

# link cross-sections (mm): (width across the arm plane, height in the arm plane)
LINK_SECTIONS = ((60.0, 60.0), (42.0, 42.0), (38.0, 38.0), (36.0, 36.0))  # waist->shoulder .. wrist->wrist_rotate
HOUSING_MM = (70.0, 40.0)                    # gripper housing across the fingers (tool y) and tool z
FINGER_ROOT_MM = 27.575                      # the fingers start this far behind the tool point (rx200.md)


@dataclass(frozen=True)
class FaceSet:
    """N convex planar polygons: vertices (N, K, 3) world mm (a polygon with fewer than K corners repeats its last
    one), outward unit normals (N, 3), base colours (N, 3) RGB 0..255."""

    vertices: np.ndarray
    normals: np.ndarray
    colors: np.ndarray

    def __len__(self) -> int:
        return len(self.vertices)

    @staticmethod
    def empty() -> FaceSet:
        return FaceSet(np.empty((0, 3, 3)), np.empty((0, 3)), np.empty((0, 3)))

    @staticmethod
    def concat(sets: list[FaceSet]) -> FaceSet:
        """One FaceSet of all faces of `sets`, in order (polygons padded to the largest corner count)."""
        sets = [s for s in sets if len(s)]
        if not sets:
            return FaceSet.empty()
        k = max(s.vertices.shape[1] for s in sets)
        return FaceSet(np.concatenate([_pad(s.vertices, k) for s in sets]),
                       np.concatenate([s.normals for s in sets]), np.concatenate([s.colors for s in sets]))

    def shaded_colors(self) -> np.ndarray:
        """(N, 3) float colours as lit: base colour x `shade` of the normal, at most 255."""
        return np.minimum(255.0, self.colors * shade(self.normals)[:, None])


def _pad(V: np.ndarray, k: int) -> np.ndarray:
    """Polygons (N, K, 3) padded to k corners by repeating the last one (harmless for a convex fill)."""
    if V.shape[1] == k:
        return V
    return np.concatenate([V, np.repeat(V[:, -1:], k - V.shape[1], axis=1)], axis=1)


def shade(normal_world: np.ndarray) -> np.ndarray | float:
    """Brightness factor of faces with these outward world normals ((3,) -> float, (N, 3) -> (N,)): 1 for an upward
    face, less when turned away from the light."""
    lit = AMBIENT + DIFFUSE * np.maximum(0.0, np.asarray(normal_world, dtype=float) @ LIGHT_DIR)
    k = lit / (AMBIENT + DIFFUSE * LIGHT_DIR[2])
    return float(k) if np.ndim(k) == 0 else k


def _prisms(polygons: np.ndarray, z0: np.ndarray, z1: np.ndarray, colors: np.ndarray, R: np.ndarray,
            centres: np.ndarray) -> FaceSet:
    """Faces of P convex polygons (P, K, 2) counter-clockwise (padded by repeating the last corner), each extruded
    from z0[p] to z1[p] (world mm) and turned by R[p] (3, 3) about centres[p] (3,); colours (P, 3)."""
    P, K = polygons.shape[:2]
    bottom = np.concatenate([polygons, np.broadcast_to(z0[:, None, None], (P, K, 1))], axis=2)
    top = np.concatenate([polygons, np.broadcast_to(z1[:, None, None], (P, K, 1))], axis=2)
    edges = np.roll(polygons, -1, axis=1) - polygons                           # (P, K, 2)
    lengths = np.linalg.norm(edges, axis=2)
    keep = lengths >= 1e-9                                                     # padding makes zero-length edges
    nxt = np.roll(np.arange(K), -1)
    sides = np.stack([bottom, bottom[:, nxt], top[:, nxt], top], axis=2)[keep]   # (S, 4, 3)
    side_n = np.zeros((len(sides), 3))
    side_n[:, 0], side_n[:, 1] = edges[keep][:, 1], -edges[keep][:, 0]
    side_n /= lengths[keep][:, None]
    side_p = np.broadcast_to(np.arange(P)[:, None], (P, K))[keep]
    k = max(K, 4)
    V = np.concatenate([_pad(top, k), _pad(bottom[:, ::-1], k), _pad(sides, k)])
    n = np.concatenate([np.tile([0.0, 0.0, 1.0], (P, 1)), np.tile([0.0, 0.0, -1.0], (P, 1)), side_n])
    owner = np.concatenate([np.arange(P), np.arange(P), side_p])
    # turn about each owner's centre: (V - c) R^T + c
    c = centres[owner][:, None, :]
    V = np.einsum("nkj,nij->nki", V - c, R[owner]) + c
    n = np.einsum("nj,nij->ni", n, R[owner])
    return FaceSet(V, n, colors[owner].astype(float))


def objects_faces(objects) -> FaceSet:
    """Faces of objects (cubes or distractors): each footprint polygon extruded from bottom_z to top_z, turned by the
    object's tilt (roll about world x, then pitch about world y, about the object centre) while it tips."""
    polys, z0, z1, colors, Rs, centres = [], [], [], [], [], []
    for obj in objects:
        tilt = np.asarray(getattr(obj, "tilt", np.zeros(2)), dtype=float)
        R = rot_y(tilt[1]) @ rot_x(tilt[0]) if np.any(tilt) else np.eye(3)
        for poly in obj.footprint_world():
            polys.append(poly)
            z0.append(obj.bottom_z)
            z1.append(obj.top_z)
            colors.append(LAB_RGB[obj.color])
            Rs.append(R)
            centres.append(obj.position)
    if not polys:
        return FaceSet.empty()
    k = max(len(p) for p in polys)
    padded = np.array([np.concatenate([p, np.repeat(p[-1:], k - len(p), axis=0)]) for p in polys], dtype=float)
    return _prisms(padded, np.array(z0, float), np.array(z1, float), np.array(colors, float), np.array(Rs),
                   np.array(centres, float))


def object_faces(obj: ObjectState) -> FaceSet:
    """Faces of one object (see `objects_faces`)."""
    return objects_faces([obj])


def _boxes(centres: np.ndarray, axes: np.ndarray, half: np.ndarray, colors: np.ndarray) -> FaceSet:
    """Six faces of each of B boxes: centres (B, 3) mm, axes (B, 3, 3) unit columns, half extents (B, 3) mm along
    them, colours (B, 3)."""
    B = len(centres)
    k = np.repeat(np.arange(3), 2)                          # face axis: +x, -x, +y, -y, +z, -z
    sign = np.tile([1.0, -1.0], 3)
    i, j = (k + 1) % 3, (k + 2) % 3
    n = axes[:, :, k] * sign                                 # (B, 3, 6) outward normals as columns
    n = np.moveaxis(n, 2, 1)                                 # (B, 6, 3)
    c = centres[:, None, :] + n * half[:, k][:, :, None]
    a = np.moveaxis(axes[:, :, i], 2, 1) * half[:, i][:, :, None]
    b = np.moveaxis(axes[:, :, j], 2, 1) * half[:, j][:, :, None]
    quad = np.stack([c - a - b, c + a - b, c + a + b, c - a + b], axis=2)   # (B, 6, 4, 3)
    return FaceSet(quad.reshape(6 * B, 4, 3), n.reshape(6 * B, 3), np.repeat(colors, 6, axis=0).astype(float))


def box_faces(centre, axes, half, color) -> FaceSet:
    """Six faces of a box: centre (3,) mm, axes (3, 3) unit columns, half extents (3,) mm along them."""
    return _boxes(np.asarray(centre, float)[None], np.asarray(axes, float)[None], np.asarray(half, float)[None],
                  np.asarray(color, float)[None])


def _segment_boxes(p0: np.ndarray, p1: np.ndarray, side: np.ndarray, width: np.ndarray, height: np.ndarray,
                   colors: np.ndarray) -> FaceSet:
    """Boxes from p0[b] to p1[b] (B, 3) mm with width[b] along side[b] (unit, perpendicular to the segment) and
    height[b] across; segments shorter than 1 um are skipped."""
    axis = p1 - p0
    length = np.linalg.norm(axis, axis=1)
    keep = length >= 1e-6
    axis = axis[keep] / length[keep][:, None]
    side = side[keep]
    axes = np.stack([axis, side, np.cross(axis, side)], axis=2)
    half = np.column_stack([length[keep] / 2, width[keep] / 2, height[keep] / 2])
    return _boxes((p0[keep] + p1[keep]) / 2, axes, half, colors[keep])


def arm_faces(q, gripper_opening_mm: float, gripper_geometry) -> FaceSet:
    """Faces of the RX200 at joint angles q (5,) rad with the fingers `gripper_opening_mm` apart (inner faces).

    gripper_geometry: an object with pad_width_mm (pad extent along the tool z axis), pad_height_mm (along the
    approach, centred on the tool point) and pad_thickness_mm (across the opening).
    """
    q = np.asarray(q, dtype=float)
    frames = link_frames(q, check_limits=False)
    P = frame_points(frames)                    # base, waist top, shoulder, elbow, wrist, wrist_rotate, tool
    tool = frames[6]
    side = np.array([np.cos(q[0]), np.sin(q[0]), 0.0])    # normal of the arm's vertical plane
    x, y = tool[:3, 0], tool[:3, 1]
    root = P[6] - FINGER_ROOT_MM * x
    sections = np.array(LINK_SECTIONS + (HOUSING_MM,))
    links = _segment_boxes(np.vstack([P[1:5], P[5]]), np.vstack([P[2:6], root]), np.vstack([np.tile(side, (4, 1)), y]),
                           sections[:, 0], sections[:, 1], np.tile(ARM_RGB, (5, 1)))
    base = box_faces((0.0, 0.0, P[1, 2] / 2), np.eye(3), (*lab_config().robot_base_half_mm, P[1, 2] / 2), ARM_RGB)
    pad_h = float(gripper_geometry.pad_height_mm)
    pad_w = float(gripper_geometry.pad_width_mm)
    thick = float(gripper_geometry.pad_thickness_mm)
    tip = P[6] + pad_h / 2 * x
    offsets = np.array([1.0, -1.0])[:, None] * (gripper_opening_mm / 2 + thick / 2) * y
    half = (np.linalg.norm(tip - root) / 2, thick / 2, pad_w / 2)
    fingers = _boxes((root + tip) / 2 + offsets, np.tile(tool[:3, :3], (2, 1, 1)), np.tile(half, (2, 1)),
                     np.tile(FINGER_RGB, (2, 1)))
    return FaceSet.concat([base, links, fingers])

"""The planar faces the simulated camera sees: blocks and distractors (extruded footprints) and the RX200 arm (boxes).

Every face is a convex polygon in the world frame (mm) with its outward unit normal and a base RGB colour (the colour
a face lit like a block's top face shows; `shade` darkens faces turned away from the light). The arm is drawn as boxes
along `armlab.kinematics.joint_positions` (links ~40 mm wide) plus the gripper housing and two fingers at the opening.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from armlab.blocks import LAB_RGB, ObjectState
from armlab.kinematics import joint_positions, link_frames
from armlab.transforms import rot_x, rot_y

__all__ = ["Face", "object_faces", "arm_faces", "box_faces", "shade", "LIGHT_DIR", "ARM_RGB", "FINGER_RGB"]

LIGHT_DIR = np.array([0.3, -0.4, 1.0]) / np.linalg.norm([0.3, -0.4, 1.0])   # towards the lab's ceiling light
AMBIENT, DIFFUSE = 0.45, 0.55
ARM_RGB = (36, 36, 38)          # the RX200's black links
FINGER_RGB = (52, 52, 54)

# link cross-sections (mm): (width across the arm plane, height in the arm plane)
BASE_HALF_MM = (55.0, 60.0)                  # the fixed base plate (x, y half extents), up to the waist top
LINK_SECTIONS = ((60.0, 60.0), (42.0, 42.0), (38.0, 38.0), (36.0, 36.0))  # waist->shoulder .. wrist->wrist_rotate
HOUSING_MM = (70.0, 40.0)                    # gripper housing across the fingers (tool y) and tool z
FINGER_ROOT_MM = 27.575                      # the fingers start this far behind the tool point (rx200.md)


@dataclass(frozen=True)
class Face:
    """A convex planar polygon: vertices (K, 3) world mm, outward unit normal (3,), base colour RGB."""

    vertices: np.ndarray
    normal: np.ndarray
    color: tuple[float, float, float]


def shade(normal_world: np.ndarray) -> float:
    """Brightness factor of a face with this outward world normal: 1 for an upward face, less when turned away."""
    lit = AMBIENT + DIFFUSE * max(0.0, float(normal_world @ LIGHT_DIR))
    return lit / (AMBIENT + DIFFUSE * LIGHT_DIR[2])


def _prism_faces(polygon_xy: np.ndarray, z0: float, z1: float, color, R: np.ndarray | None,
                 centre: np.ndarray) -> list[Face]:
    """Faces of a convex polygon (K, 2) counter-clockwise, extruded from z0 to z1 (world mm), optionally turned by
    R (3, 3) about `centre`."""
    K = len(polygon_xy)
    bottom = np.column_stack([polygon_xy, np.full(K, z0)])
    top = np.column_stack([polygon_xy, np.full(K, z1)])
    faces = [(top, np.array([0.0, 0.0, 1.0])), (bottom[::-1], np.array([0.0, 0.0, -1.0]))]
    edges = np.roll(polygon_xy, -1, axis=0) - polygon_xy
    lengths = np.linalg.norm(edges, axis=1)
    for i in range(K):
        if lengths[i] < 1e-9:
            continue
        j = (i + 1) % K
        n = np.array([edges[i, 1], -edges[i, 0], 0.0]) / lengths[i]
        faces.append((np.array([bottom[i], bottom[j], top[j], top[i]]), n))
    if R is not None:
        faces = [((V - centre) @ R.T + centre, R @ n) for V, n in faces]
    return [Face(V, n, color) for V, n in faces]


def object_faces(obj: ObjectState) -> list[Face]:
    """Faces of one object (cube or distractor): its footprint polygons extruded from bottom_z to top_z, turned by
    its tilt (roll about world x, then pitch about world y, about the object centre) while it tips."""
    tilt = np.asarray(getattr(obj, "tilt", np.zeros(2)), dtype=float)
    R = rot_y(tilt[1]) @ rot_x(tilt[0]) if np.any(tilt) else None
    color = LAB_RGB[obj.color]
    faces: list[Face] = []
    for poly in obj.footprint_world():
        faces += _prism_faces(poly, obj.bottom_z, obj.top_z, color, R, obj.position)
    return faces


def box_faces(centre, axes, half, color) -> list[Face]:
    """Six faces of a box: centre (3,) mm, axes (3, 3) unit columns, half extents (3,) mm along them."""
    centre, axes, half = (np.asarray(a, dtype=float) for a in (centre, axes, half))
    faces = []
    for k in range(3):
        i, j = (k + 1) % 3, (k + 2) % 3
        for sign in (1.0, -1.0):
            n = sign * axes[:, k]
            c = centre + n * half[k]
            a, b = axes[:, i] * half[i], axes[:, j] * half[j]
            quad = np.array([c - a - b, c + a - b, c + a + b, c - a + b])
            faces.append(Face(quad, n, color))
    return faces


def _segment_box(p0, p1, side, width: float, height: float, color) -> list[Face]:
    """A box from p0 to p1 (mm) with `width` along `side` (unit, perpendicular to the segment) and `height` across."""
    axis = p1 - p0
    length = float(np.linalg.norm(axis))
    if length < 1e-6:
        return []
    axis = axis / length
    third = np.cross(axis, side)
    return box_faces((p0 + p1) / 2, np.column_stack([axis, side, third]), (length / 2, width / 2, height / 2), color)


def arm_faces(q, gripper_opening_mm: float, gripper_geometry) -> list[Face]:
    """Faces of the RX200 at joint angles q (5,) rad with the fingers `gripper_opening_mm` apart (inner faces).

    gripper_geometry: an object with pad_width_mm (pad extent along the tool z axis), pad_height_mm (along the
    approach, centred on the tool point) and pad_thickness_mm (across the opening).
    """
    q = np.asarray(q, dtype=float)
    P = joint_positions(q)                      # base, waist top, shoulder, elbow, wrist, wrist_rotate, tool
    tool = link_frames(q, check_limits=False)[6]
    side = np.array([np.cos(q[0]), np.sin(q[0]), 0.0])    # normal of the arm's vertical plane
    faces = box_faces((0.0, 0.0, P[1, 2] / 2), np.eye(3), (*BASE_HALF_MM, P[1, 2] / 2), ARM_RGB)
    for k, (w, h) in enumerate(LINK_SECTIONS):
        faces += _segment_box(P[k + 1], P[k + 2], side, w, h, ARM_RGB)
    x, y, z = tool[:3, 0], tool[:3, 1], tool[:3, 2]
    root = P[6] - FINGER_ROOT_MM * x
    faces += _segment_box(P[5], root, y, *HOUSING_MM, ARM_RGB)
    pad_h = float(gripper_geometry.pad_height_mm)
    pad_w = float(gripper_geometry.pad_width_mm)
    thick = float(gripper_geometry.pad_thickness_mm)
    tip = P[6] + pad_h / 2 * x
    for sign in (1.0, -1.0):
        offset = sign * (gripper_opening_mm / 2 + thick / 2) * y
        centre = (root + tip) / 2 + offset
        faces += box_faces(centre, np.column_stack([x, y, z]),
                           (np.linalg.norm(tip - root) / 2, thick / 2, pad_w / 2), FINGER_RGB)
    return faces

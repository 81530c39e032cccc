"""Image masks for detection: the board area and the arm (from its joint angles, not a fixed rectangle)."""

from __future__ import annotations

import cv2
import numpy as np

from armlab.camera import Camera
from armlab.kinematics import joint_positions

__all__ = ["arm_mask", "ARM_RADIUS_MM"]

ARM_RADIUS_MM = 45.0  # half-width of the arm's links and gripper with a margin (mm)


def arm_mask(camera: Camera, q, radius_mm: float = ARM_RADIUS_MM, samples_per_link: int = 12) -> np.ndarray:
    """(H, W) bool mask of the pixels the arm at joint angles q (5,) rad may cover.

    Each link (between consecutive points of kinematics.joint_positions, plus the fingers beyond the tool point)
    is swept as a capsule of `radius_mm`: points along it are projected and drawn as discs of the projected radius.
    """
    q = np.asarray(q, float)
    points = joint_positions(q)
    approach = points[-1] - points[-2]
    approach /= np.linalg.norm(approach)
    points = np.vstack([points, points[-1] + 20.0 * approach])  # finger tips beyond the tool point
    t = np.linspace(0, 1, samples_per_link)[:, None, None]
    seg = points[:-1][None] * (1 - t) + points[1:][None] * t      # (S, L, 3)
    seg = seg.reshape(-1, 3)
    uv = camera.project(seg)
    depth = camera.depth_of(seg)
    mask = np.zeros(camera.image_shape, np.uint8)
    fx = camera.K[0, 0]
    for (u, v), z in zip(uv, depth):
        if not np.isfinite(u) or z <= 1:
            continue
        r = int(np.ceil(radius_mm * fx / z))
        cv2.circle(mask, (int(round(u)), int(round(v))), r, 1, -1)
    return mask.astype(bool)

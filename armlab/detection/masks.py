"""Image masks for detection: the board area and the arm (from its joint angles, not a fixed rectangle)."""

from __future__ import annotations

import cv2
import numpy as np

from armlab.camera import Camera
from armlab.gripper_geometry import GRIPPER
from armlab.kinematics import joint_positions

__all__ = ["arm_mask", "ARM_RADIUS_MM"]

ARM_RADIUS_MM = 45.0  # half-width of the arm's links and gripper with a margin (mm)


def arm_mask(camera: Camera, q, radius_mm: float = ARM_RADIUS_MM, samples_per_link: int = 12,
             step: int = 1) -> np.ndarray:
    """(H, W) bool mask of the pixels the arm at joint angles q (5,) rad may cover; with step > 1, the mask of
    every step-th pixel ((H + step - 1) // step, (W + step - 1) // step), drawn directly at that resolution.

    Each link (between consecutive points of kinematics.joint_positions, plus the fingers: GRIPPER.fingertip_mm
    beyond the tool point along the approach) is swept as a capsule of `radius_mm`: points along it are projected and
    drawn as discs of the projected radius.
    """
    q = np.asarray(q, float)
    if q.shape != (5,) or not np.all(np.isfinite(q)):
        raise ValueError(f"arm_q must be 5 finite joint angles (rad), got shape {q.shape}")
    if int(step) < 1:
        raise ValueError(f"step must be a positive integer, got {step}")
    points = joint_positions(q)
    approach = points[-1] - points[-2]
    approach /= np.linalg.norm(approach)
    points = np.vstack([points, points[-1] + GRIPPER.fingertip_mm * approach])  # the finger tips
    t = np.linspace(0, 1, samples_per_link)[:, None, None]
    seg = points[:-1][None] * (1 - t) + points[1:][None] * t      # (S, L, 3)
    seg = seg.reshape(-1, 3)
    depth = camera.depth_of(seg)
    uv = camera.project(seg) / step
    ok = np.isfinite(uv).all(axis=1) & (depth > 1)
    radius = np.ceil(radius_mm * camera.K[0, 0] / (step * np.where(ok, depth, 1.0))).astype(int)
    H, W = camera.image_shape
    mask = np.zeros(((H + step - 1) // step, (W + step - 1) // step), np.uint8)
    for (u, v), r in zip(np.rint(uv[ok]).astype(int), radius[ok]):
        cv2.circle(mask, (int(u), int(v)), int(r), 1, -1)
    return mask.astype(bool)

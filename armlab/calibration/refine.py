"""Refine the extrinsic from depth: tilt the board plane T_cam_world predicts onto the plane the depth camera sees.

The AprilTag extrinsic fixes the board's pose from 16 corner pixels; the depth image measures the board plane
directly with every board pixel. Back-projected through the intrinsics, the board's pixels give camera-frame points
p_c = Z (x, y, 1) (x, y: undistorted normalised coordinates); a plane n . p_c = d is fitted to them robustly (blocks
and the arm are rejected as outliers). The extrinsic is then rotated by the smallest rotation that turns its board
normal onto n, about the board point seen at the inliers' centroid, and moved along n to the fitted distance d.
Depth says nothing about where the board lies within its plane, so the position along the board and the yaw stay the
tags'. Note that a depth bias that is planar in the image (the L515's tilt, see armlab.calibration.depth) is read as
a board tilt: refine before correcting the depth only when the depth is known to be unbiased.
Units: mm (camera and world frames), degrees in the report fields.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from armlab.calibration.depth import board_samples
from armlab.camera import Camera
from armlab.transforms import exp_so3, homogeneous

__all__ = ["PlaneRefinement", "fit_plane", "refine_extrinsic_from_depth", "MAX_TILT_DEG"]

MAX_TILT_DEG = 10.0     # a depth plane farther than this from the extrinsic's is a wrong extrinsic, not a refinement


@dataclass(frozen=True)
class PlaneRefinement:
    """The refined T_cam_world (4, 4), the rotation applied (deg), the change in the camera's height above the board
    (mm, + = the camera is higher than the tags said), the board plane in the camera frame (unit normal towards the
    camera, n . p = distance_mm), the RMS distance of the inliers from it (mm) and how many there were."""

    T_cam_world: np.ndarray
    tilt_deg: float
    height_change_mm: float
    normal: np.ndarray
    distance_mm: float
    residual_mm: float
    inliers: int


def fit_plane(points, inlier_mm: float = 6.0, iterations: int = 6) -> tuple[np.ndarray, float, np.ndarray]:
    """Robust least-squares plane n . p = d through points (N, 3) mm: fit (principal axes of the inliers), drop the
    points farther than inlier_mm, refit. Returns the unit normal n (3,) (sign: d >= 0), d (mm) and the inlier mask
    (N,). Raises ValueError for fewer than 3 finite points or a degenerate (collinear) set."""
    P = np.asarray(points, dtype=float)
    if P.ndim != 2 or P.shape[1] != 3:
        raise ValueError(f"points must have shape (N, 3), got {P.shape}")
    keep = np.all(np.isfinite(P), axis=1)
    finite = keep.copy()
    for _ in range(max(1, int(iterations))):
        if keep.sum() < 3:
            raise ValueError(f"a plane needs at least 3 points, got {int(keep.sum())} inliers")
        centre = P[keep].mean(axis=0)
        _, s, vt = np.linalg.svd(P[keep] - centre, full_matrices=False)
        if s[1] < 1e-9 * max(s[0], 1.0):
            raise ValueError("the points are collinear: they do not define a plane")
        n = vt[2]
        with np.errstate(invalid="ignore"):
            keep = finite & (np.abs((P - centre) @ n) < inlier_mm)
    d = float(n @ centre)
    if d < 0:
        n, d = -n, -d
    return n, d, keep


def refine_extrinsic_from_depth(depth_mm, camera: Camera, step: int = 4, inlier_mm: float = 6.0,
                                exclude=None) -> PlaneRefinement:
    """Refine camera.T_cam_world (e.g. the AprilTag extrinsic) from a depth image (H, W) mm of the board (see the
    module notes): the board pixels (on a grid of `step` px, `exclude` (H, W) bool pixels left out) are
    back-projected, a plane is fitted (fit_plane), and the extrinsic's tilt and height are moved onto it.
    Raises ValueError when too few board pixels have depth."""
    u, v, measured, _, _, first = board_samples(depth_mm, camera, step, exclude)
    uv = np.column_stack([u[first], v[first]]).astype(float)
    points = camera.pixel_to_camera(uv, measured[first])
    n1, d1, inliers = fit_plane(points, inlier_mm)
    R0, t0 = camera.T_cam_world[:3, :3], camera.T_cam_world[:3, 3]
    n0 = R0[:, 2]                                 # world +z (the board normal, towards the camera) in the camera frame
    d0 = float(n0 @ t0)                           # the board plane z = 0 is n0 . p = d0 in the camera frame
    if n1 @ n0 < 0:                               # orient the fit like the extrinsic's normal
        n1, d1 = -n1, -d1
    off = float(np.degrees(np.arccos(np.clip(n1 @ n0, -1.0, 1.0))))
    if off > MAX_TILT_DEG or d1 * d0 <= 0:
        raise ValueError(f"the board plane in the depth image is {off:.1f} deg from the extrinsic's (at most "
                         f"{MAX_TILT_DEG:.0f} deg is a refinement): are the extrinsic and the depth of this camera?")
    centre = points[inliers].mean(axis=0)         # on (near) the measured plane
    pivot = centre * d0 / (n0 @ centre)           # where the ray through it meets the extrinsic's plane
    axis = np.cross(n0, n1)
    angle = float(np.arctan2(np.linalg.norm(axis), n0 @ n1))
    Q = exp_so3(axis / np.linalg.norm(axis), angle) if angle > 1e-12 else np.eye(3)
    target = centre * d1 / (n1 @ centre)          # ... and the fitted plane: the board point there keeps its pixel
    T = homogeneous(Q @ R0, Q @ (t0 - pivot) + target)
    residual = (points[inliers] @ n1) - d1
    return PlaneRefinement(T, float(np.degrees(angle)), abs(d1) - abs(d0), n1, float(abs(d1)),
                           float(np.sqrt(np.mean(residual**2))), int(inliers.sum()))

"""Extrinsic calibration: the camera's pose over the board from the board's AprilTags (solvePnP on all corners).

Result: T_cam_world (4, 4) mapping world (board) points in mm into the camera frame in mm.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from armlab.calibration.tags import TagDetection, detect_tags
from armlab.camera import check_intrinsics, look_at
from armlab.images import check_rgb
from armlab.lab import TagLayout, lab_config
from armlab.transforms import homogeneous, invert_transform, log_so3

__all__ = ["ExtrinsicsResult", "calibrate_extrinsics", "extrinsics_from_detections", "hand_measured_extrinsic",
           "compare_extrinsics"]


@dataclass(frozen=True)
class ExtrinsicsResult:
    """T_cam_world (4, 4) mm, RMS reprojection error of the tag corners (px), ids used, ids missing, detections."""

    T_cam_world: np.ndarray
    rms_px: float
    tag_ids: list[int]
    missing_ids: list[int]
    detections: list[TagDetection]


def extrinsics_from_detections(detections: list[TagDetection], K, dist,
                               layout: TagLayout | None = None) -> ExtrinsicsResult:
    """Board pose from tag detections: solvePnP (SQPNP, then Levenberg-Marquardt refinement) over every corner
    (IPPE when only one tag is seen). Tags that are not on the board are ignored.

    Raises ValueError when no tag of the layout was detected.

    Exercise calib.tag_extrinsics (notebook 01: the camera's pose from the AprilTag corners (PnP)).
    """
    K, dist = check_intrinsics(K, dist)
    layout = layout or lab_config().tags
    best: dict[int, TagDetection] = {}
    for d in detections:  # one detection per board tag: the most confident, should a tag be seen twice
        if d.tag_id in layout.centres_mm and (d.tag_id not in best
                                              or d.decision_margin > best[d.tag_id].decision_margin):
            best[d.tag_id] = d
    known = [best[i] for i in sorted(best)]
    missing = sorted(set(layout.centres_mm) - {d.tag_id for d in known})
    if not known:
        raise ValueError(f"no board AprilTag (ids {sorted(layout.centres_mm)}, family {layout.family}) was "
                         f"detected: check the board is in view and lit, and the tag family")
    world = np.concatenate([layout.corners_world(d.tag_id) for d in known])
    pixels = np.concatenate([d.corners for d in known])
    # BEGIN SOLUTION calib.tag_extrinsics
    if len(known) == 1:
        ok, rvec, tvec = cv2.solvePnP(world, pixels, K, dist, flags=cv2.SOLVEPNP_IPPE)
    else:
        ok, rvec, tvec = cv2.solvePnP(world, pixels, K, dist, flags=cv2.SOLVEPNP_SQPNP)
    if not ok:
        raise ValueError("solvePnP failed on the detected tag corners")
    rvec, tvec = cv2.solvePnPRefineLM(world, pixels, K, dist, rvec, tvec)
    T = homogeneous(cv2.Rodrigues(rvec)[0], tvec.ravel())
    # END SOLUTION
    proj, _ = cv2.projectPoints(world, rvec, tvec, K, dist)
    rms = float(np.sqrt(np.mean(np.sum((proj.reshape(-1, 2) - pixels) ** 2, axis=1))))
    return ExtrinsicsResult(T, rms, [d.tag_id for d in known], missing, known)


def calibrate_extrinsics(rgb, K, dist, layout: TagLayout | None = None, quad_decimate: float = 1.0) -> ExtrinsicsResult:
    """Camera pose T_cam_world from one RGB uint8 (H, W, 3) frame showing the board's AprilTags.

    K (3, 3) and dist are the intrinsics to use (factory or checkerboard-calibrated).
    """
    rgb = check_rgb(rgb)
    layout = layout or lab_config().tags
    return extrinsics_from_detections(detect_tags(rgb, layout.family, quad_decimate), K, dist, layout)


def hand_measured_extrinsic(position_mm=None, look_at_mm=None) -> np.ndarray:
    """The extrinsic a student would measure with a tape: the nominal mount of data/lab.json (camera position and
    the board point its optical axis meets), with image-up towards +y. Returns T_cam_world (4, 4)."""
    cfg = lab_config()
    return look_at(cfg.camera_position_mm if position_mm is None else position_mm,
                   cfg.camera_look_at_mm if look_at_mm is None else look_at_mm)


def compare_extrinsics(T_a, T_b) -> dict[str, float]:
    """How far apart two extrinsics T_cam_world (4, 4) put the camera: the camera centres' distance (mm, and per world
    axis a - b), and the angle (deg) of the rotation between the two camera orientations."""
    T_a, T_b = np.asarray(T_a, float), np.asarray(T_b, float)
    if T_a.shape != (4, 4) or T_b.shape != (4, 4):
        raise ValueError(f"extrinsics must be 4x4 transforms, got shapes {T_a.shape} and {T_b.shape}")
    d = invert_transform(T_a)[:3, 3] - invert_transform(T_b)[:3, 3]
    angle = np.linalg.norm(log_so3(T_a[:3, :3] @ T_b[:3, :3].T))
    return {"position_mm": float(np.linalg.norm(d)), "dx_mm": float(d[0]), "dy_mm": float(d[1]),
            "dz_mm": float(d[2]), "angle_deg": float(np.degrees(angle))}

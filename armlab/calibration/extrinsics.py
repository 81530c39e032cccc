"""Extrinsic calibration: the camera's pose over the board from the board's AprilTags (a planar pose from all corners).

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
from armlab.slots import standin
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


def _opencv_pose(world_mm, pixels, K, dist, refine: bool = True) -> np.ndarray:
    """The reference path while calib.tag_extrinsics is blank: OpenCV's solvePnP (IPPE for one tag's four corners,
    SQPNP otherwise), then (refine) the same Levenberg-Marquardt refinement."""
    world, pixels = np.asarray(world_mm, np.float64), np.asarray(pixels, np.float64)
    ok, rvec, tvec = cv2.solvePnP(world, pixels, K, dist,
                                  flags=cv2.SOLVEPNP_IPPE if len(world) == 4 else cv2.SOLVEPNP_SQPNP)
    if not ok:
        raise ValueError("solvePnP failed on the detected tag corners")
    if not refine:
        return homogeneous(cv2.Rodrigues(rvec)[0], tvec.ravel())
    rvec, tvec = cv2.solvePnPRefineLM(world, pixels, K, dist, rvec, tvec)
    return homogeneous(cv2.Rodrigues(rvec)[0], tvec.ravel())


def _refined(world, pixels, K, dist, R, t) -> np.ndarray:
    """T_cam_world after Levenberg-Marquardt on the reprojection error (with the lens distortion), from R, t."""
    rvec, tvec = cv2.solvePnPRefineLM(world, pixels, K, dist, cv2.Rodrigues(np.asarray(R, np.float64))[0],
                                      np.asarray(t, np.float64).reshape(3, 1))
    return homogeneous(cv2.Rodrigues(rvec)[0], tvec.ravel())


@standin("calib.tag_extrinsics", _opencv_pose, "the camera pose comes from cv2.solvePnP")
def pose_from_corners(world_mm, pixels, K, dist, refine: bool = True) -> np.ndarray:
    """T_cam_world (4, 4) that maps the board points world_mm (N, 3) mm (N >= 4, all on the board: z = 0) onto their
    image corners pixels (N, 2) px through K (3, 3) and dist.

    A planar pose: the board is a plane, so its points and their undistorted, normalised image points are related
    by a homography (yours: dlt_homography), from which the rotation and translation follow (notebook 01 derives
    how). The kit's own pose takes that homography from OpenCV, never from the student's dlt_homography: the kit's
    truth runs no student code. With refine (the default), Levenberg-Marquardt on the reprojection error (with the
    lens distortion) then polishes it; refine=False returns the planar pose itself. Raises ValueError for points
    off the board.

    Exercise calib.tag_extrinsics (notebook 01: the camera's pose from the AprilTag corners).
    """
    from armlab.calibration.homography import dlt_homography  # noqa: F401 (the tool of the student's region)

    world, pixels = np.asarray(world_mm, dtype=np.float64), np.asarray(pixels, dtype=np.float64)
    if world.ndim != 2 or world.shape[1] != 3 or pixels.shape != (len(world), 2) or len(world) < 4:
        raise ValueError(f"pose_from_corners needs N >= 4 board points (N, 3) and pixels (N, 2), got "
                         f"{world.shape} and {pixels.shape}")
    if np.abs(world[:, 2]).max() > 1e-9:
        raise ValueError(f"pose_from_corners needs points on the board (z = 0); the highest is at "
                         f"{np.abs(world[:, 2]).max():.3g} mm")
    normalised = cv2.undistortPoints(pixels.reshape(-1, 1, 2), K, dist).reshape(-1, 2)
    # BEGIN SOLUTION calib.tag_extrinsics
    from armlab.calibration.homography import opencv_homography

    H = opencv_homography(world[:, :2], normalised)
    scale = 2.0 / (np.linalg.norm(H[:, 0]) + np.linalg.norm(H[:, 1]))
    if H[2, 2] * scale < 0:                     # t_z = scale * H[2, 2] must be positive: the board is in front
        scale = -scale
    r1, r2, t = H[:, 0] * scale, H[:, 1] * scale, H[:, 2] * scale
    U, _, Vt = np.linalg.svd(np.column_stack([r1, r2, np.cross(r1, r2)]))
    R = U @ np.diag([1.0, 1.0, np.linalg.det(U @ Vt)]) @ Vt
    # END SOLUTION
    if not refine:
        return homogeneous(R, np.asarray(t, dtype=float).ravel())
    return _refined(world, pixels, K, dist, R, t)


def extrinsics_from_detections(detections: list[TagDetection], K, dist,
                               layout: TagLayout | None = None) -> ExtrinsicsResult:
    """Board pose from tag detections: pose_from_corners over every corner of the board's tags (the most confident
    detection of each; tags not on the board are ignored), and the corners' RMS reprojection error (px).

    Raises ValueError when no tag of the layout was detected.
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
    T = pose_from_corners(world, pixels, K, dist)
    proj, _ = cv2.projectPoints(world, cv2.Rodrigues(T[:3, :3])[0], T[:3, 3], K, dist)
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

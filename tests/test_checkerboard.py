"""Simulated checkerboard captures and the saved calibration set in data/checkerboard/."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from armlab.sim.camera import CameraRealism, true_camera
from armlab.sim.checkerboard import Checkerboard, checkerboard_poses, load_dataset, render_checkerboard

FLAGS = cv2.CALIB_CB_ADAPTIVE_THRESH | cv2.CALIB_CB_NORMALIZE_IMAGE
SUBPIX = (cv2.TERM_CRITERIA_EPS | cv2.TERM_CRITERIA_MAX_ITER, 50, 1e-4)


def corners(gray, pattern=(9, 6)):
    ok, c = cv2.findChessboardCorners(gray, pattern, flags=FLAGS)
    assert ok, "checkerboard not found"
    return cv2.cornerSubPix(gray, c, (7, 7), (-1, -1), SUBPIX).reshape(-1, 2)


def test_rendered_corners_are_where_the_true_camera_puts_them():
    realism = replace_noise_off(CameraRealism())
    camera = true_camera(realism)
    board = Checkerboard()
    T = checkerboard_poses(camera, 3, seed=5)[1]
    rgb, depth = render_checkerboard(camera, T, realism)
    found = corners(cv2.cvtColor(rgb, cv2.COLOR_RGB2GRAY))
    expected = camera.project_camera(board.object_points() @ T[:3, :3].T + T[:3, 3])
    # OpenCV may list the corners from either end
    err = min(np.abs(found - expected).max(), np.abs(found[::-1] - expected).max())
    assert err < 0.15
    # the card's depth is its plane's: the centre of the card is at T's translation
    u, v = np.rint(camera.project_camera(T[None, :3, 3])[0]).astype(int)
    hit = camera.normalized_rays(np.array([[u, v]], float))[0]
    n, p = T[:3, 2], T[:3, 3]
    assert depth[v, u] == pytest.approx((n @ p) / (n @ np.append(hit, 1.0)), abs=0.02)


def replace_noise_off(realism):
    from dataclasses import replace
    ideal = CameraRealism.ideal()
    return replace(ideal, **{k: getattr(realism, k) for k in ("mount_offset_mm", "mount_rotvec_rad", "focal_scale",
                                                              "principal_offset_px", "distortion")})


def test_poses_are_varied_tilted_and_inside_the_image():
    camera = true_camera(CameraRealism())
    board = Checkerboard()
    poses = checkerboard_poses(camera, 16, seed=2)
    assert len(poses) == 16
    assert all(np.array_equal(a, b) for a, b in zip(poses, checkerboard_poses(camera, 16, seed=2)))
    tilts = np.degrees([np.arccos(T[2, 2]) for T in poses])
    assert tilts.max() <= 40.0 + 1e-6 and tilts.max() > 25 and np.median(tilts) > 10
    centres = np.array([camera.project_camera(T[None, :3, 3])[0] for T in poses])
    assert np.ptp(centres[:, 0]) > 400 and np.ptp(centres[:, 1]) > 150
    for T in poses:
        uv = camera.project_camera(board.card_corners() @ T[:3, :3].T + T[:3, 3])
        assert np.all((uv >= 0) & (uv < (camera.width, camera.height)))


def test_saved_set_calibrates_to_the_true_intrinsics():
    images, meta = load_dataset()
    assert 15 <= len(images) <= 20
    assert tuple(meta["pattern_size"]) == (9, 6) and meta["square_mm"] == 25.0
    board = Checkerboard(tuple(meta["pattern_size"]), meta["square_mm"])
    image_points = [corners(g) for g in images]            # every view must be found
    object_points = [board.object_points()] * len(images)
    rms, K, dist, _, _ = cv2.calibrateCamera(object_points, image_points, tuple(meta["image_size"]), None, None)
    K_true = np.array(meta["true_K"])
    assert rms < 0.3
    assert abs(K[0, 0] / K_true[0, 0] - 1) < 0.005 and abs(K[1, 1] / K_true[1, 1] - 1) < 0.005
    assert np.abs(K[:2, 2] - K_true[:2, 2]).max() < 0.005 * K_true[0, 0]
    # the saved set's truth is the realistic SimCamera's (seed in the metadata)
    truth = true_camera(CameraRealism.realistic(meta["seed"]))
    assert np.allclose(truth.K, K_true) and np.allclose(truth.dist, meta["true_dist"])


def test_load_dataset_names_a_missing_folder(tmp_path):
    with pytest.raises(ValueError, match="checkerboard.json"):
        load_dataset(tmp_path)


def test_bad_pose_is_refused():
    camera = true_camera(CameraRealism.ideal())
    with pytest.raises(ValueError, match="T_cam_target"):
        render_checkerboard(camera, np.eye(3))

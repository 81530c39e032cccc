"""Simulated checkerboard captures and the saved calibration set in data/checkerboard/."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from armlab import calibration as cal
from armlab import make_station
from armlab.sim.camera import CameraRealism, true_camera
from armlab.sim.checkerboard import (
    Checkerboard,
    capture_checkerboard_set,
    checkerboard_poses,
    load_dataset,
    render_checkerboard,
    sim_camera_intrinsics,
)

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
    assert np.array_equal(np.stack(poses), np.stack(checkerboard_poses(camera, 16, seed=2)))   # same count, same poses
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


# -- a station's own set ------------------------------------------------------------------------------------------
def test_each_camera_photographs_its_own_set_and_calibrates_to_its_own_truth():
    a = make_station("sim", seed=2, scene="empty").camera
    b = make_station("sim", seed=5, scene="empty").camera
    assert not np.allclose(a.truth.K, b.truth.K)
    views = capture_checkerboard_set(a, n=3)
    assert len(views) == 3 and views[0].shape == (720, 1280, 3) and views[0].dtype == np.uint8
    assert np.array_equal(np.stack(views), np.stack(capture_checkerboard_set(a, n=3)))   # same camera, same set
    assert not np.array_equal(views[0], capture_checkerboard_set(b, n=1)[0])
    for camera in (a, b):
        result = sim_camera_intrinsics(camera)
        diff = cal.compare_intrinsics(result.K, camera.truth.K)
        assert abs(diff["focal_rel_pct"]) < 0.1 and max(abs(diff["dcx_px"]), abs(diff["dcy_px"])) < 1.5, diff
        assert result.used_views == list(range(16)) and result.rms < 0.3
    # cached per camera: a second station with the same camera gets the same result without rendering again
    assert sim_camera_intrinsics(make_station("sim", seed=2, scene="random").camera) is sim_camera_intrinsics(a)
    # the saved seed-0 set is another camera's: the principal point of camera a is several px away from it
    images, meta = load_dataset()
    other = cal.calibrate_intrinsics(images, (9, 6), 25.0)
    assert np.abs(other.K[:2, 2] - a.truth.K[:2, 2]).max() > 4.0


def test_capture_needs_a_simulated_camera():
    with pytest.raises(TypeError, match="simulated camera"):
        capture_checkerboard_set(object())
    with pytest.raises(ValueError, match="at least 3 views"):
        sim_camera_intrinsics(make_station("sim", seed=0, scene="empty").camera, n=2)


# -- set files ----------------------------------------------------------------------------------------------------
def test_a_saved_set_loads_back_and_calibrates_alike(tmp_path):
    images, meta = load_dataset()
    rgb = [np.repeat(g[..., None], 3, axis=2) for g in images[:6]]        # a camera's RGB frames
    folder = cal.save_checkerboard_set(rgb, tmp_path / "mine", (9, 6), 25.0, notes={"camera": "L515 f0123"})
    again, meta2 = cal.load_checkerboard_set(folder)
    assert meta2["camera"] == "L515 f0123" and meta2["image_size"] == [1280, 720] and len(again) == 6
    assert meta2["pattern_size"] == [9, 6] and meta2["square_mm"] == 25.0
    assert np.abs(np.stack(again).astype(int) - np.stack(images[:6])).max() < 12    # JPEG 95 of a JPEG 95
    K1 = cal.calibrate_intrinsics(again, (9, 6), 25.0).K
    K0 = cal.calibrate_intrinsics(images[:6], (9, 6), 25.0).K
    assert np.abs(K1 - K0).max() < 0.5
    assert sorted(p.name for p in folder.iterdir()) == ["checkerboard.json"] + [f"view_{i:02d}.jpg" for i in range(6)]


@pytest.mark.parametrize("images, kwargs, match", [
    ([], {}, "at least one image"),
    (np.zeros((720, 1280), np.uint8), {}, "list of images"),
    ([np.zeros((72, 128), np.uint8), np.zeros((48, 64), np.uint8)], {}, "the first is 128x72"),
    ([np.zeros((72, 128), np.float32)], {}, "uint8"),
    ([np.zeros((72, 128), np.uint8)], {"pattern_size": (1, 6)}, "INNER corners"),
    ([np.zeros((72, 128), np.uint8)], {"notes": {"images": []}}, "notes may not set"),
])
def test_bad_sets_are_refused_before_anything_is_written(tmp_path, images, kwargs, match):
    with pytest.raises(ValueError, match=match):
        cal.save_checkerboard_set(images, tmp_path / "set", **kwargs)
    assert not (tmp_path / "set").exists()


def test_missing_or_corrupt_sets_are_named(tmp_path):
    with pytest.raises(ValueError, match="folder not found"):
        cal.load_checkerboard_set(tmp_path / "nowhere")
    folder = cal.save_checkerboard_set([np.full((72, 128), 200, np.uint8)] * 2, tmp_path / "set")
    (folder / "view_01.jpg").unlink()
    with pytest.raises(ValueError, match="view_01.jpg: missing"):
        cal.load_checkerboard_set(folder)
    (folder / "view_01.jpg").write_bytes((folder / "view_00.jpg").read_bytes())
    meta = (folder / "checkerboard.json").read_text()
    (folder / "checkerboard.json").write_text(meta.replace("128", "64"))
    with pytest.raises(ValueError, match="128x72 image in a 64x72 set"):
        cal.load_checkerboard_set(folder)
    (folder / "checkerboard.json").write_text(meta[:40])
    with pytest.raises(ValueError, match=r"checkerboard\.json: not valid JSON, a corrupt checkerboard metadata file"):
        cal.load_checkerboard_set(folder)
    (folder / "checkerboard.json").write_text(meta.replace('"square_mm"', '"square"'))
    with pytest.raises(ValueError, match=r"checkerboard\.json: square_mm: missing"):
        cal.load_checkerboard_set(folder)

"""armlab.calibration against the simulator's ground truth: checkerboard intrinsics, AprilTag extrinsics, top-down
views, depth-plane correction, grid validation and calibration files; bad input gives clear errors."""

from __future__ import annotations

import json

import cv2
import numpy as np
import pytest

from armlab import calibration as cal
from armlab import make_station
from armlab.camera import Camera
from armlab.lab import lab_config
from armlab.sim.camera import CameraRealism
from armlab.sim.checkerboard import load_dataset

LAB = lab_config()


# -- shared captures ----------------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def dataset():
    images, meta = load_dataset()
    return images, meta


@pytest.fixture(scope="module")
def intrinsics(dataset):
    images, meta = dataset
    return cal.calibrate_intrinsics(images, tuple(meta["pattern_size"]), meta["square_mm"])


@pytest.fixture(scope="module")
def station(dataset):
    """The empty board under the camera that took the checkerboard set (same realistic device)."""
    return make_station("sim", seed=0, scene="empty", camera_realism=CameraRealism.realistic(dataset[1]["seed"]))


@pytest.fixture(scope="module")
def frame(station):
    return station.camera.capture()


@pytest.fixture(scope="module")
def tags(frame):
    return cal.detect_tags(frame.rgb)


def model_error_px(camera: Camera, K, dist, step: int = 20) -> np.ndarray:
    """Pixel distance (N,) over the image between where `camera` and the intrinsics (K, dist) put the same rays."""
    v, u = np.mgrid[0:camera.height:step, 0:camera.width:step]
    uv = np.column_stack([u.ravel(), v.ravel()]).astype(float)
    rays = np.column_stack([camera.normalized_rays(uv), np.ones(len(uv))])
    return np.linalg.norm(camera.with_intrinsics(K, dist).project_camera(rays) - uv, axis=1)


# -- intrinsics ---------------------------------------------------------------------------------------------------
def test_checkerboard_set_recovers_the_true_intrinsics(dataset, intrinsics):
    _, meta = dataset
    K_true = np.array(meta["true_K"])
    diff = cal.compare_intrinsics(intrinsics.K, K_true)
    assert abs(diff["focal_rel_pct"]) < 0.1
    assert abs(diff["dfx_px"]) < 1.0 and abs(diff["dfy_px"]) < 1.0
    assert abs(diff["dcx_px"]) < 1.5 and abs(diff["dcy_px"]) < 1.5
    assert intrinsics.rms < 0.3 and len(intrinsics.per_view_rms) == 16 and intrinsics.per_view_rms.max() < 0.5
    assert intrinsics.used_views == list(range(16)) and intrinsics.rejected_views == {}
    assert intrinsics.image_size == (1280, 720)
    # the whole lens model (K and distortion), not just K: the same rays land within 1.5 px everywhere
    truth = Camera(K_true, meta["true_dist"], np.eye(4))
    assert model_error_px(truth, intrinsics.K, intrinsics.dist).max() < 1.5
    # and the factory K the device reports is >1 % off in focal length (like the lab report's 1.2 % / 1.5 %)
    assert cal.compare_intrinsics(LAB.factory_K, K_true)["focal_rel_pct"] > 1.0


def test_fixing_k3_leaves_pixels_of_error_in_the_corners(dataset, intrinsics):
    images, meta = dataset
    fixed = cal.calibrate_intrinsics(images, (9, 6), 25.0, fix_k3=True)
    truth = Camera(np.array(meta["true_K"]), meta["true_dist"], np.eye(4))
    assert fixed.dist[4] == 0.0
    assert model_error_px(truth, fixed.K, fixed.dist).max() > 5.0       # the simulated lens has k3 = 0.2
    assert abs(intrinsics.dist[4] - meta["true_dist"][4]) < 0.05


def test_rgb_and_gray_views_calibrate_alike_and_blank_views_are_rejected(dataset):
    images, _ = dataset
    gray = cal.calibrate_intrinsics(images[:6], (9, 6), 25.0)
    rgb = cal.calibrate_intrinsics([np.repeat(g[..., None], 3, axis=2) for g in images[:5]]
                                   + [np.full_like(images[0], 128)] + [images[5]], (9, 6), 25.0)
    assert rgb.used_views == [0, 1, 2, 3, 4, 6] and list(rgb.rejected_views) == [5]
    assert "checkerboard" in rgb.rejected_views[5]
    assert np.allclose(rgb.K, gray.K, atol=0.5)


@pytest.mark.parametrize("images, kwargs, match", [
    ([], {}, "got none"),
    ([np.zeros((720, 1280), np.float32)] * 3, {}, "uint8"),
    ([np.zeros((720, 1280, 4), np.uint8)] * 3, {}, "shape"),
    ([np.zeros((720, 1280), np.uint8), np.zeros((480, 640), np.uint8)], {}, "480"),
    (np.zeros((720, 1280, 3), np.uint8), {}, "list of images"),
    ([np.zeros((72, 128), np.uint8)] * 3, {"pattern_size": (1, 6)}, "INNER corners"),
    ([np.zeros((72, 128), np.uint8)] * 3, {"pattern_size": (9.5, 6)}, "INNER corners"),
    ([np.zeros((72, 128), np.uint8)] * 3, {"square_mm": -25.0}, "square_mm"),
    ([np.zeros((72, 128), np.uint8)] * 3, {"min_views": 2}, "min_views"),
])
def test_bad_checkerboard_input_is_named(images, kwargs, match):
    with pytest.raises(ValueError, match=match):
        cal.calibrate_intrinsics(images, **kwargs)


def test_too_few_views_or_the_wrong_pattern_say_so(dataset):
    images, _ = dataset
    with pytest.raises(ValueError, match="found in 2 of 2 images"):
        cal.calibrate_intrinsics(images[:2], (9, 6), 25.0)
    with pytest.raises(ValueError, match="found in 0 of 3 images.*INNER"):
        cal.calibrate_intrinsics(images[:3], (10, 7), 25.0)


# -- a station's own intrinsics -----------------------------------------------------------------------------------
@pytest.mark.exercise("calib.tag_extrinsics", "calib.depth_plane")
def test_a_station_is_calibrated_with_its_own_cameras_checkerboard_set():
    from armlab.tasks import perception

    station = make_station("sim", seed=2, scene="empty")
    truth = station.camera.truth
    own = perception.calibrate_camera(station)
    K, dist = perception.station_intrinsics(station)
    assert np.array_equal(own.camera.K, K) and np.array_equal(own.camera.dist, dist)
    assert abs(cal.compare_intrinsics(K, truth.K)["focal_rel_pct"]) < 0.1
    good = cal.compare_extrinsics(own.camera.T_cam_world, truth.T_cam_world)
    # the saved seed-0 set's K (another camera's) puts this camera's centre more than 5 mm off
    other = perception.calibrate_camera(station, perception.checkerboard_intrinsics())
    bad = cal.compare_extrinsics(other.camera.T_cam_world, truth.T_cam_world)
    assert good["position_mm"] < 1.5 and good["angle_deg"] < 0.1 and bad["position_mm"] > 5.0, (good, bad)


def test_a_real_station_reads_the_set_saved_from_its_camera(tmp_path, monkeypatch, dataset):
    from types import SimpleNamespace

    from armlab.station import Capabilities
    from armlab.tasks import perception

    monkeypatch.setenv("ARMLAB_DATA", str(tmp_path))
    real = SimpleNamespace(capabilities=Capabilities(), camera=SimpleNamespace(width=1280, height=720))
    with pytest.raises(ValueError, match=f"{tmp_path / 'checkerboard_real'}: no checkerboard set for this camera"):
        perception.station_intrinsics(real)
    images, _ = dataset
    cal.save_checkerboard_set(images[:8], tmp_path / "checkerboard_real")
    K, dist = perception.station_intrinsics(real)
    assert np.allclose(K, cal.calibrate_intrinsics(images[:8], (9, 6), 25.0).K, atol=0.5) and dist.shape == (5,)
    small = SimpleNamespace(capabilities=Capabilities(), camera=SimpleNamespace(width=640, height=480))
    with pytest.raises(ValueError, match="1280x720 px, the camera's images 640x480"):
        perception.station_intrinsics(small)


# -- AprilTags and extrinsics -------------------------------------------------------------------------------------
def test_tag_corners_are_where_the_true_camera_projects_them(station, tags):
    truth = station.camera.truth
    assert [t.tag_id for t in tags] == [1, 2, 3, 4] and all(t.hamming == 0 for t in tags)
    err = np.concatenate([t.corners - truth.project(LAB.tags.corners_world(t.tag_id)) for t in tags])
    assert np.abs(err).max() < 0.5
    assert np.abs(err.mean(axis=0)).max() < 0.1     # no half-pixel offset left: the +0.5 convention is handled


def test_decodes_with_corrected_bits_are_dropped():
    marker = cv2.aruco.generateImageMarker(cv2.aruco.getPredefinedDictionary(cv2.aruco.DICT_APRILTAG_36h11), 7, 80,
                                           borderBits=1)
    image = np.full((200, 200), 255, np.uint8)
    image[60:140, 60:140] = np.rot90(marker, 2)      # OpenCV draws tags turned 180 deg (toolchain.md)
    assert [(t.tag_id, t.hamming) for t in cal.detect_tags(image)] == [(7, 0)]
    image[90:100, 90:100] = 255 - image[90:100, 90:100]    # flip one data bit
    assert cal.detect_tags(image) == []
    assert [(t.tag_id, t.hamming) for t in cal.detect_tags(image, max_hamming=2)] == [(7, 1)]


@pytest.mark.exercise("calib.tag_extrinsics")
def test_tag_extrinsic_accuracy_depends_on_the_intrinsics(station, tags, intrinsics):
    truth = station.camera.truth
    with_true = cal.extrinsics_from_detections(tags, truth.K, truth.dist)
    with_checkerboard = cal.extrinsics_from_detections(tags, intrinsics.K, intrinsics.dist)
    with_factory = cal.extrinsics_from_detections(tags, station.camera.K, station.camera.dist)
    for result, max_mm, max_deg in [(with_true, 1.0, 0.1), (with_checkerboard, 1.0, 0.1)]:
        diff = cal.compare_extrinsics(result.T_cam_world, truth.T_cam_world)
        assert diff["position_mm"] < max_mm and diff["angle_deg"] < max_deg, diff
        assert result.tag_ids == [1, 2, 3, 4] and result.missing_ids == [] and result.rms_px < 0.5
    assert cal.compare_extrinsics(with_factory.T_cam_world, truth.T_cam_world)["position_mm"] > 10.0


def test_hand_measured_extrinsic_is_the_nominal_mount(station):
    realism = station.camera.realism
    diff = cal.compare_extrinsics(station.camera.truth.T_cam_world, cal.hand_measured_extrinsic())
    assert [diff["dx_mm"], diff["dy_mm"], diff["dz_mm"]] == pytest.approx(list(realism.mount_offset_mm), abs=1e-9)
    assert diff["angle_deg"] == pytest.approx(np.degrees(np.linalg.norm(realism.mount_rotvec_rad)), abs=1e-9)


def test_calibrate_extrinsics_from_the_frame_ignores_foreign_tags(frame, tags, intrinsics):
    direct = cal.calibrate_extrinsics(frame.rgb, intrinsics.K, intrinsics.dist)
    spurious = cal.TagDetection(509, np.array([[600.0, 500], [640, 500], [640, 460], [600, 460]]),
                                np.array([620.0, 480]), 60.0)
    noisy = cal.extrinsics_from_detections([*tags, spurious], intrinsics.K, intrinsics.dist)
    assert np.allclose(direct.T_cam_world, noisy.T_cam_world) and 509 not in noisy.tag_ids


@pytest.mark.exercise("calib.tag_extrinsics")
def test_one_tag_still_gives_a_pose_and_names_the_missing_ones(tags, intrinsics):
    result = cal.extrinsics_from_detections(tags[:1], intrinsics.K, intrinsics.dist)
    assert result.tag_ids == [1] and result.missing_ids == [2, 3, 4] and result.rms_px < 1.0


def test_no_tags_or_bad_frames_are_named(intrinsics):
    with pytest.raises(ValueError, match="no board AprilTag"):
        cal.calibrate_extrinsics(np.full((720, 1280, 3), 200, np.uint8), intrinsics.K, intrinsics.dist)
    with pytest.raises(ValueError, match="uint8"):
        cal.calibrate_extrinsics(np.zeros((720, 1280, 3), np.float32), intrinsics.K, intrinsics.dist)
    with pytest.raises(ValueError, match="3x3"):
        cal.extrinsics_from_detections([], np.eye(2), np.zeros(5))
    with pytest.raises(ValueError, match="family"):
        cal.detect_tags(np.zeros((50, 50), np.uint8), family="tag99h99")


def test_tag_detectors_are_shared_for_the_life_of_the_process():
    # pupil-apriltags' Detector.__del__ crashes the interpreter now and then: one detector per setting, freed at exit
    from armlab.calibration.tags import pupil_detector

    assert pupil_detector("tag36h11", 2.0) is pupil_detector("tag36h11", 2.0)
    assert pupil_detector("tag36h11", 1.0) is not pupil_detector("tag36h11", 2.0)


# -- top-down views -----------------------------------------------------------------------------------------------
def test_board_view_puts_the_tags_where_they_are_on_the_board(station, frame):
    view = cal.BoardView(station.camera.truth, mm_per_px=1.0)
    top = view.warp(frame.rgb)
    assert top.shape == (650, 1000, 3)
    found = cal.detect_tags(top)
    assert [t.tag_id for t in found] == [1, 2, 3, 4]
    for t in found:
        assert np.abs(t.center - view.from_world([LAB.tags.centres_mm[t.tag_id]])[0]).max() < 0.3
    assert np.allclose(view.to_world(view.from_world([[-123.0, 45.0]])), [[-123.0, 45.0]])
    with pytest.raises(ValueError, match="camera is 1280x720"):
        view.warp(np.zeros((10, 10, 3), np.uint8))
    with pytest.raises(ValueError, match="mm_per_px"):
        cal.BoardView(station.camera.truth, mm_per_px=0)


def test_four_tag_homography_is_exact_at_the_tags_and_off_at_the_borders(station, tags):
    truth = station.camera.truth
    view = cal.BoardView(truth, mm_per_px=1.0)
    H = cal.tag_homography(tags, view)

    def board_error(points):
        mapped = cv2.perspectiveTransform(truth.project(points).reshape(-1, 1, 2), H).reshape(-1, 2)
        return np.linalg.norm(view.to_world(mapped) - points[:, :2], axis=1)

    centres = np.array([[x, y, 0.0] for x, y in LAB.tags.centres_mm.values()])
    corners = np.array([[x, y, 0.0] for x in LAB.board_x for y in LAB.board_y])
    assert board_error(centres).max() < 0.5              # fitted there (up to the detection noise)
    assert board_error(corners).max() > 3.0              # lens distortion the homography cannot model
    with pytest.raises(ValueError, match=r"missing ids \[3\]"):
        cal.tag_homography([t for t in tags if t.tag_id != 3], view)


# -- pixel + depth <-> world --------------------------------------------------------------------------------------
def test_pixel_and_depth_round_trip_through_a_calibration(station):
    truth = station.camera.truth
    depth, on_board = cal.board_depth(truth)            # the exact depth image of the empty board
    assert depth.shape == (720, 1280) and on_board.mean() > 0.5
    rng = np.random.default_rng(3)
    points = np.column_stack([rng.uniform(-450, 450, 50), rng.uniform(-150, 450, 50), np.zeros(50)])
    calibration = cal.Calibration(truth)
    back = calibration.pixel_to_world(truth.project(points), depth.astype(np.float32), radius=0)
    # nearest-pixel depth on a tilted plane: error below the plane's depth change over half a pixel
    assert np.abs(back - points).max() < 1.0
    exact = truth.pixel_to_world(truth.project(points), truth.depth_of(points))
    assert np.abs(exact - points).max() < 1e-6


# -- depth correction ---------------------------------------------------------------------------------------------
@pytest.mark.exercise("calib.depth_plane")
def test_depth_correction_recovers_a_known_plane_exactly(station):
    truth = station.camera.truth
    depth, _ = cal.board_depth(truth)
    v, u = np.mgrid[0:720, 0:1280]
    bias = 0.01 * u - 0.02 * v + 4.0
    measured = (depth + bias).astype(np.float32)
    measured[300:340, 600:660] -= 38.0                  # a block on the board: rejected as an outlier
    measured[:, :40] = np.nan                           # no return along one edge
    fit = cal.fit_depth_correction(measured, truth)
    assert (fit.a, fit.b, fit.c) == pytest.approx((0.01, -0.02, 4.0), abs=1e-3)
    assert fit.residual_mm < 0.01
    corrected = fit.apply(measured)
    assert np.isnan(corrected[:, :40]).all()
    assert np.nanmax(np.abs(corrected - depth)[400:, 100:]) < 0.05


@pytest.mark.exercise("calib.depth_plane")
def test_depth_correction_recovers_the_simulated_bias(station, frame):
    truth = station.camera.truth
    bu, bv, b0 = station.camera.realism.depth_bias_mm
    fit = cal.fit_depth_correction(frame.depth, truth)
    v, u = np.mgrid[0:720:8, 0:1280:8]
    true_bias = bu * (u / 1280 - 0.5) + bv * (v / 720 - 0.5) + b0
    assert np.abs(fit.bias((720, 1280))[::8, ::8] - true_bias).max() < 1.0
    assert fit.span_mm((720, 1280)) == pytest.approx(abs(bu) * 1279 / 1280 + abs(bv) * 719 / 720, abs=1.0)
    assert 1.0 < fit.residual_mm < 4.0                  # the sensor noise (2.5 mm at 1 m, more on dark print)


def test_depth_correction_refuses_unusable_depth(station):
    truth = station.camera.truth
    with pytest.raises(ValueError, match="board pixels"):
        cal.fit_depth_correction(np.full((720, 1280), np.nan, np.float32), truth)
    with pytest.raises(ValueError, match="shape"):
        cal.fit_depth_correction(np.zeros((480, 640), np.float32), truth)
    with pytest.raises(ValueError, match="dtype"):
        cal.fit_depth_correction(np.zeros((720, 1280), np.uint16), truth)


# -- extrinsic refinement from depth ------------------------------------------------------------------------------
def _tilted(T_cam_world, axis_world, angle_deg, shift_world):
    """T_cam_world with the board turned by angle_deg about a world axis through the origin, then shifted (mm)."""
    from armlab.transforms import exp_so3, homogeneous

    R = exp_so3(np.asarray(axis_world, float) / np.linalg.norm(axis_world), np.radians(angle_deg))
    return T_cam_world @ homogeneous(R, shift_world)


def test_refinement_puts_the_board_plane_where_exact_depth_sees_it(station):
    truth = station.camera.truth
    depth, on_board = cal.board_depth(truth)
    depth = depth.astype(np.float32)
    depth[300:340, 600:660] -= 38.0                     # a block: an outlier
    depth[:, :40] = np.nan                              # no return along one edge
    wrong = truth.with_pose(_tilted(truth.T_cam_world, [1.0, 0.4, 0.0], 0.8, [0.0, 0.0, -9.0]))
    ref = cal.refine_extrinsic_from_depth(depth, wrong)
    wrong_height = abs(wrong.T_cam_world[:3, 2] @ wrong.T_cam_world[:3, 3])    # camera to the board plane it thinks
    assert ref.tilt_deg == pytest.approx(0.8, abs=1e-4)
    assert ref.height_change_mm == pytest.approx(truth.position[2] - wrong_height, abs=1e-3)
    assert abs(ref.height_change_mm) > 3.0
    assert ref.residual_mm < 1e-3 and ref.inliers > 20000
    refined = truth.with_pose(ref.T_cam_world)
    # the refined camera predicts the depth image of the true one (depth fixes the plane: tilt and height) ...
    assert np.nanmax(np.abs(cal.board_depth(refined)[0] - cal.board_depth(truth)[0])[on_board]) < 1e-3
    assert np.degrees(np.arccos(refined.T_cam_world[:3, 2] @ truth.T_cam_world[:3, 2])) < 1e-4
    # ... and its plane, as fitted: unit normal towards the camera, distance = the camera's height over the board
    assert ref.normal @ truth.T_cam_world[:3, 2] == pytest.approx(1.0, abs=1e-9)
    assert ref.distance_mm == pytest.approx(truth.position[2], abs=1e-3)
    # the exact extrinsic is left alone
    same = cal.refine_extrinsic_from_depth(depth, truth)
    assert same.tilt_deg < 1e-5 and abs(same.height_change_mm) < 1e-3
    assert np.abs(same.T_cam_world - truth.T_cam_world).max() < 1e-3


def test_refinement_cannot_see_along_the_board(station):
    truth = station.camera.truth
    depth = cal.board_depth(truth)[0].astype(np.float32)
    slid = truth.T_cam_world @ _tilted(np.eye(4), [0, 0, 1], 1.5, [6.0, -4.0, 0.0])     # yaw and shift in the plane
    ref = cal.refine_extrinsic_from_depth(depth, truth.with_pose(slid))
    assert ref.tilt_deg < 1e-5 and abs(ref.height_change_mm) < 1e-3
    assert np.abs(ref.T_cam_world - slid).max() < 1e-3          # nothing to correct that depth can see


@pytest.mark.exercise("calib.depth_plane")
def test_a_planar_depth_bias_is_read_as_a_tilt(station, frame, tags, intrinsics):
    # the realistic L515 depth is tilted ~20 mm across the image: the refinement turns the board by about a degree
    # and the grid error after depth correction grows (the refinement does not help on biased depth)
    truth = station.camera.truth
    camera = Camera(intrinsics.K, intrinsics.dist, cal.extrinsics_from_detections(tags, intrinsics.K,
                                                                                  intrinsics.dist).T_cam_world)
    ref = cal.refine_extrinsic_from_depth(frame.depth, camera)
    assert 0.5 < ref.tilt_deg < 3.0
    grid = LAB.grid_points()
    uv = truth.project(grid)
    visible = cal.visible_grid_points(truth, frame.depth, grid, uv)
    errors = []
    for cam in (camera, camera.with_pose(ref.T_cam_world)):
        corrected = cal.fit_depth_correction(frame.depth, cam).apply(frame.depth)
        errors.append(cal.grid_world_error(cam, corrected, grid[visible], uv[visible]).mean_mm)
    assert errors[1] > 1.5 * errors[0], errors


@pytest.mark.exercise("calib.tag_extrinsics", "calib.depth_plane")
def test_refinement_fixes_the_height_of_a_factory_k_extrinsic_on_unbiased_depth():
    from dataclasses import replace

    realism = replace(CameraRealism.realistic(2), depth_bias_mm=(0.0, 0.0, 0.0))
    station = make_station("sim", seed=2, scene="empty", camera_realism=realism)
    truth, frame = station.camera.truth, station.camera.capture()
    K, dist = station.camera.K, station.camera.dist                  # factory: ~1 % off in focal length
    camera = Camera(K, dist, cal.calibrate_extrinsics(frame.rgb, K, dist).T_cam_world)
    refined = camera.with_pose(cal.refine_extrinsic_from_depth(frame.depth, camera).T_cam_world)
    grid = LAB.grid_points()
    uv = truth.project(grid)
    visible = cal.visible_grid_points(truth, frame.depth, grid, uv)
    before, after = (cal.grid_world_error(c, frame.depth, grid[visible], uv[visible]) for c in (camera, refined))
    assert before.mean_mm > 4.0 and after.mean_mm < 0.5 * before.mean_mm, (before.summary(), after.summary())
    z = [abs(np.nanmean(g.error[:, 2])) for g in (before, after)]
    assert z[1] < 1.0 < z[0]                                          # the board's height is right again


def test_bad_refinement_input_is_named(station):
    truth = station.camera.truth
    with pytest.raises(ValueError, match="board pixels"):
        cal.refine_extrinsic_from_depth(np.full((720, 1280), np.nan, np.float32), truth)
    with pytest.raises(ValueError, match="align depth"):
        cal.refine_extrinsic_from_depth(np.zeros((480, 640), np.float32), truth)
    with pytest.raises(ValueError, match="exclude"):
        cal.refine_extrinsic_from_depth(cal.board_depth(truth)[0], truth, exclude=np.zeros((10, 10), bool))
    far = truth.with_pose(_tilted(truth.T_cam_world, [1, 0, 0], 12.0, [0, 0, 0]))
    with pytest.raises(ValueError, match="deg from the extrinsic"):
        cal.refine_extrinsic_from_depth(cal.board_depth(truth)[0], far)
    with pytest.raises(ValueError, match="collinear"):
        cal.fit_plane(np.outer(np.arange(10.0), [1, 2, 3]))
    with pytest.raises(ValueError, match="at least 3"):
        cal.fit_plane(np.array([[0, 0, 1.0], [1, 0, 1], [np.nan, 0, 0]]))
    with pytest.raises(ValueError, match=r"\(N, 3\)"):
        cal.fit_plane(np.zeros((5, 2)))


# -- validation on the 50 mm grid ---------------------------------------------------------------------------------
@pytest.mark.exercise("calib.tag_extrinsics", "calib.depth_plane")
def test_grid_error_before_and_after_calibration(station, frame, tags, intrinsics):
    truth = station.camera.truth
    grid = LAB.grid_points()
    uv = truth.project(grid)
    visible = cal.visible_grid_points(truth, frame.depth, grid, uv)
    # the sleeping arm and its base hide the points near the origin, nothing else
    assert 240 <= visible.sum() < len(grid)
    assert not visible[np.all(grid[:, :2] == [0, 25], axis=1)].any()
    assert visible[np.abs(grid[:, 0]) >= 150].all()
    grid, uv = grid[visible], uv[visible]

    before = cal.grid_world_error(Camera(station.camera.K, station.camera.dist, cal.hand_measured_extrinsic()),
                                  frame.depth, grid, uv)
    extrinsic = cal.extrinsics_from_detections(tags, intrinsics.K, intrinsics.dist)
    camera = Camera(intrinsics.K, intrinsics.dist, extrinsic.T_cam_world)
    correction = cal.fit_depth_correction(frame.depth, camera)
    after = cal.grid_world_error(camera, correction.apply(frame.depth), grid, uv)
    assert before.mean_mm > 10.0
    assert after.mean_mm < 2.0 and after.max_mm < 5.0
    assert abs(after.border_growth()) < 0.2
    assert after.summary().startswith(f"mean {after.mean_mm:.2f} mm")
    # the same through a Calibration
    via = cal.Calibration(camera, correction).pixel_to_world(uv, frame.depth)
    assert np.allclose(via, after.estimate, equal_nan=True)


def test_border_growth_measures_a_known_slope():
    world = np.array([[x, y, 0.0] for x in (-200.0, 0.0, 200.0) for y in (-200.0, 0.0, 200.0)])
    r = np.linalg.norm(world[:, :2], axis=1)
    error = np.column_stack([0.03 * r + 1.0, np.zeros(9), np.zeros(9)])     # 3 mm per 100 mm, plus 1 mm
    g = cal.GridError(world, world + error, error)
    assert g.border_growth() == pytest.approx(3.0)
    assert g.mean_mm == pytest.approx(np.mean(0.03 * r + 1.0))
    with pytest.raises(ValueError, match="at least 3"):
        cal.GridError(world[:2], world[:2], np.zeros((2, 3))).border_growth()


def test_grid_input_shapes_are_checked(station, frame):
    truth = station.camera.truth
    with pytest.raises(ValueError, match="grid_uv has 2"):
        cal.grid_world_error(truth, frame.depth, np.zeros((3, 3)), np.zeros((2, 2)))
    with pytest.raises(ValueError, match=r"grid_world must have shape \(N, 3\)"):
        cal.grid_world_error(truth, frame.depth, np.zeros((3, 2)), np.zeros((3, 2)))
    with pytest.raises(ValueError, match="align depth"):
        cal.visible_grid_points(truth, frame.depth[:100], np.zeros((3, 3)), np.zeros((3, 2)))


# -- calibration files --------------------------------------------------------------------------------------------
@pytest.fixture()
def calibration(station):
    return cal.Calibration(station.camera.truth, cal.DepthCorrection(0.01, -0.02, 3.5, 2.4, 1000), notes="test")


def test_save_and_load_round_trip(tmp_path, calibration):
    path = cal.save_calibration(calibration, tmp_path / "sub" / "calibration.json")
    loaded = cal.load_calibration(path)
    for name in ("K", "dist", "T_cam_world"):
        assert np.array_equal(getattr(loaded.camera, name), getattr(calibration.camera, name))
    assert loaded.depth_correction == calibration.depth_correction and loaded.notes == "test"
    assert (loaded.camera.width, loaded.camera.height) == (1280, 720)
    assert [p.name for p in path.parent.iterdir()] == ["calibration.json"]    # no temporary file left


def test_missing_corrupt_or_wrong_files_are_named(tmp_path, calibration):
    with pytest.raises(cal.CalibrationFileError, match="not found"):
        cal.load_calibration(tmp_path / "nope.json")
    with pytest.raises(cal.CalibrationFileError, match="folder"):
        cal.load_calibration(tmp_path)
    good = calibration.to_dict()
    cases = {
        "corrupt.json": ('{"format": "armlab-calibration/1", "K": [[1, 0', "not valid JSON"),
        "wrong.json": (json.dumps({"format": "something-else"}), "not an armlab calibration"),
        "list.json": (json.dumps([1, 2, 3]), "not an armlab calibration"),
        "missing.json": (json.dumps({k: v for k, v in good.items() if k != "T_cam_world"}), "T_cam_world: missing"),
        "nan.json": (json.dumps({**good, "K": [[float("nan"), 0, 640], [0, 900, 360], [0, 0, 1]]}),
                     r"K\[0\]\[0\]: must be a finite number, got NaN"),
        "shape.json": (json.dumps({**good, "dist": [0.1, 0.2]}), "dist: has 2 values"),
        "rigid.json": (json.dumps({**good, "T_cam_world": (2 * np.eye(4)).tolist()}), "T_cam_world: .*rigid"),
        "dc.json": (json.dumps({**good, "depth_correction": {"a": float("inf")}}),
                    r"depth_correction\.a: must be a finite number, got Infinity"),
        "dctype.json": (json.dumps({**good, "depth_correction": [1, 2]}), "depth_correction: must be of type object"),
    }
    for name, (text, match) in cases.items():
        (tmp_path / name).write_text(text)
        with pytest.raises(cal.CalibrationFileError, match=match) as err:
            cal.load_calibration(tmp_path / name)
        assert name in str(err.value)


def test_a_failed_save_leaves_the_old_file_intact(tmp_path, calibration, station):
    path = cal.save_calibration(calibration, tmp_path / "calibration.json")
    before = path.read_bytes()
    with pytest.raises(ValueError, match=r"DepthCorrection\.a contains NaN"):
        cal.DepthCorrection(float("nan"), 0.0, 0.0)
    correction = cal.DepthCorrection()
    object.__setattr__(correction, "a", float("nan"))        # corrupted after construction: the write still refuses
    broken = cal.Calibration(station.camera.truth, correction)
    with pytest.raises(ValueError):
        cal.save_calibration(broken, path)
    assert path.read_bytes() == before
    assert [p.name for p in tmp_path.iterdir()] == ["calibration.json"]
    with pytest.raises(TypeError, match="Calibration"):
        cal.save_calibration({"K": 1}, path)
    with pytest.raises(TypeError, match="Camera"):
        cal.Calibration("camera")

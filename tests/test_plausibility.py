"""Plausibility checks where a silent answer would mislead: zero depth is "no return" wherever depth is read, a
negative depth is refused, copies of one checkerboard view are not a calibration, a colour image with no board in
it gives no blocks (with a FrameWarning saying why), and a BGR image is refused (NotRGBError)."""

from __future__ import annotations

import numpy as np
import pytest

from armlab import calibration as cal
from armlab import make_station
from armlab._paths import data_path
from armlab.detection import detect_blocks
from armlab.detection.detect import FrameWarning, NotRGBError


@pytest.fixture(scope="module")
def scene():
    station = make_station("sim", seed=0)
    frame = station.camera.capture()
    camera, q = station.camera.truth, station.arm.joint_positions()
    depth = cal.fit_depth_correction(frame.depth, camera).apply(frame.depth)
    return frame.rgb, depth, camera, q, detect_blocks(frame.rgb, depth, camera, q)


def test_a_depth_image_of_zeros_is_no_return_not_a_correction(scene):
    _, depth, camera, _, _ = scene
    with pytest.raises(ValueError, match="only 0 board pixels have usable depth"):
        cal.fit_depth_correction(np.zeros_like(depth), camera)
    holes = depth.copy()
    holes[:300] = 0.0                                   # the top rows without a return: the fit uses the rest
    assert cal.fit_depth_correction(holes, camera).inliers > 1000


def test_zero_depth_back_projects_to_nan_and_negative_depth_is_refused(scene):
    _, depth, camera, _, _ = scene
    uv = np.array([[640.0, 360.0], [700.0, 400.0]])
    p = camera.pixel_to_world(uv, [0.0, 900.0])
    assert np.isnan(p[0]).all() and np.isfinite(p[1]).all()
    with pytest.raises(ValueError, match="depth_mm must not be negative"):
        camera.pixel_to_world(uv, [-5.0, 900.0])
    calib = cal.Calibration(camera)
    assert np.isnan(calib.pixel_to_world(uv, np.zeros_like(depth))).all()
    with pytest.raises(ValueError, match="depth_mm has 1 negative values"):
        bad = depth.copy()
        bad[10, 10] = -1.0
        calib.pixel_to_world(uv, bad)


def test_copies_of_one_checkerboard_view_are_not_a_calibration():
    images, meta = cal.load_checkerboard_set(data_path("checkerboard"))
    with pytest.raises(ValueError, match="found in 5 of 5 images, 4 of them near-duplicates.*leaves 1 distinct"):
        cal.calibrate_intrinsics([images[0]] * 5, (9, 6), 25.0)
    # a shifted copy (1 px) is a near-duplicate too; distinct views are kept and calibrate as before
    shifted = np.roll(images[1], 1, axis=1)
    result = cal.calibrate_intrinsics([images[0], images[1], shifted, images[2], images[3], images[0]], (9, 6), 25.0)
    assert result.used_views == [0, 1, 3, 4]
    assert set(result.rejected_views) == {2, 5} and "near-duplicate of images[1]" in result.rejected_views[2]
    assert "near-duplicate of images[0]" in result.rejected_views[5]


@pytest.mark.parametrize("kind", ["black", "white", "noise", "grey"])
def test_a_colour_image_without_the_board_gives_no_blocks_and_says_why(scene, kind):
    rgb, depth, camera, q, found = scene
    assert len(found) >= 4
    image = {"black": np.zeros_like(rgb), "white": np.full_like(rgb, 255), "grey": np.full_like(rgb, 128),
             "noise": np.random.default_rng(0).integers(0, 256, rgb.shape, dtype=np.uint8)}[kind]
    with pytest.warns(FrameWarning, match="no blocks reported: .*(no board|noise|one colour)"):
        assert detect_blocks(image, depth, camera, q) == []


def test_a_bgr_frame_is_refused_and_the_rgb_one_reads_as_before(scene):
    rgb, depth, camera, q, found = scene
    with pytest.raises(NotRGBError, match="looks like BGR.*COLOR_BGR2RGB"):
        detect_blocks(np.ascontiguousarray(rgb[..., ::-1]), depth, camera, q)
    again = detect_blocks(rgb, depth, camera, q)
    assert [(b.color, b.size) for b in again] == [(b.color, b.size) for b in found]

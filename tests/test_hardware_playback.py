"""The camera through the real librealsense, no camera: a synthetic scene with known depth is recorded through an
rs.software_device and rs.recorder, then replayed by make_station("real", arm=False, playback=...) through the
unmodified backend (rs.config.enable_device_from_file, the real pipeline, rs.align).

pyrealsense2 2.54.x has wheels for CPython 3.10/3.11 on x86-64 only and needs the system's libusb-1.0; elsewhere
these tests skip saying so.
"""

from __future__ import annotations

import time

import numpy as np
import pytest

from armlab import make_station
from armlab.hardware import realsense

try:
    import pyrealsense2 as rs
except ImportError as e:       # no wheel for this Python/platform, or no libusb-1.0
    pytest.skip(f"pyrealsense2 is not importable ({e}): `pip install 'pyrealsense2==2.54.*'` (CPython 3.10/3.11, "
                "x86-64) or a newer pyrealsense2 elsewhere, plus the system's libusb-1.0", allow_module_level=True)

W, H, DW, DH = 1280, 720, 1024, 768
DEPTH_UNITS_M = 0.00025
COEFFS = [0.1, -0.2, 0.001, -0.001, 0.05]


def _stream(kind, uid, w, h, fmt, bpp, fx, fy):
    s = rs.video_stream()
    s.type, s.index, s.uid, s.width, s.height, s.fps, s.bpp, s.fmt = kind, 0, uid, w, h, 30, bpp, fmt
    intr = rs.intrinsics()
    intr.width, intr.height, intr.fx, intr.fy, intr.ppx, intr.ppy = w, h, fx, fy, w / 2, h / 2
    intr.model, intr.coeffs = rs.distortion.brown_conrady, COEFFS
    s.intrinsics = intr
    return s


def record_scene(path, depth_raw: np.ndarray, frames: int = 3) -> np.ndarray:
    """Record `frames` framesets of a colour gradient and the given raw depth (DH, DW) uint16; returns the BGR."""
    dev = rs.software_device()
    depth_sensor, color_sensor = dev.add_sensor("Depth"), dev.add_sensor("Color")
    dp = depth_sensor.add_video_stream(_stream(rs.stream.depth, 0, DW, DH, rs.format.z16, 2, 740.0, 740.0))
    cp = color_sensor.add_video_stream(_stream(rs.stream.color, 1, W, H, rs.format.bgr8, 3, 900.0, 901.0))
    depth_sensor.add_read_only_option(rs.option.depth_units, DEPTH_UNITS_M)
    same_place = rs.extrinsics()
    same_place.rotation, same_place.translation = [1, 0, 0, 0, 1, 0, 0, 0, 1], [0, 0, 0]
    dp.register_extrinsics_to(cp, same_place)
    v, u = np.mgrid[0:H, 0:W]
    bgr = np.stack([u % 256, v % 256, np.full_like(u, 90)], axis=-1).astype(np.uint8)
    recorder = rs.recorder(str(path), dev)
    depth_sensor.open(dp)
    color_sensor.open(cp)
    depth_sensor.start(lambda f: None)
    color_sensor.start(lambda f: None)
    for i in range(frames):
        for sensor, profile, pixels, bpp in ((depth_sensor, dp, depth_raw, 2), (color_sensor, cp, bgr, 3)):
            f = rs.software_video_frame()
            f.pixels, f.bpp, f.stride = pixels, bpp, pixels.shape[1] * bpp
            f.timestamp, f.domain, f.frame_number = 1000.0 + 33.3 * i, rs.timestamp_domain.system_time, i
            f.profile = profile.as_video_stream_profile()
            sensor.on_video_frame(f)
        time.sleep(0.05)
    for sensor in (depth_sensor, color_sensor):
        sensor.stop()
        sensor.close()
    del recorder                        # the file is complete once the recorder is gone
    return bgr


@pytest.fixture(scope="module")
def plane_bag(tmp_path_factory):
    path = tmp_path_factory.mktemp("rs") / "plane.bag"
    raw = np.full((DH, DW), 4000, np.uint16)           # a plane 4000 * 0.25 mm = 1000 mm away
    bgr = record_scene(path, raw)
    return path, bgr


def test_playback_returns_the_recorded_frames_aligned_in_mm(plane_bag):
    path, bgr = plane_bag
    with make_station("real", arm=False, playback=str(path)) as st:
        cam = st.camera
        assert st.arm is None and (cam.width, cam.height) == (W, H)
        np.testing.assert_allclose(cam.K, [[900, 0, 640], [0, 901, 360], [0, 0, 1]])
        np.testing.assert_allclose(cam.dist, COEFFS, rtol=1e-6)
        assert cam.depth_scale_m == pytest.approx(DEPTH_UNITS_M)
        frames = [cam.capture() for _ in range(4)]            # loops: more captures than recorded frames
    frame = frames[0]
    assert frame.rgb.shape == (H, W, 3) and frame.rgb.dtype == np.uint8
    np.testing.assert_array_equal(frame.rgb, bgr[..., ::-1])
    assert frame.depth.shape == (H, W) and frame.depth.dtype == np.float32
    valid = np.isfinite(frame.depth)
    assert frame.valid_depth_fraction == pytest.approx(valid.mean()) and frame.depth_ok
    assert valid[200:520, 300:980].all()                      # the middle of the colour image sees the plane
    np.testing.assert_allclose(frame.depth[valid], 1000.0, atol=1e-3)
    assert frame.timestamp == pytest.approx(1.0, abs=1e-3)
    assert frames[1].timestamp == pytest.approx(1.0333, abs=1e-3)


def test_mostly_invalid_depth_is_flagged(tmp_path):
    raw = np.zeros((DH, DW), np.uint16)
    raw[:100, :100] = 4000
    path = tmp_path / "covered.bag"
    record_scene(path, raw, frames=2)
    with make_station("real", arm=False, playback=path) as st:
        with pytest.warns(RuntimeWarning, match="of the depth image has a return"):
            frame = st.camera.capture()
    assert not frame.depth_ok and frame.valid_depth_fraction < 0.05


def test_playback_errors_are_clear(tmp_path):
    with pytest.raises(FileNotFoundError, match="python -m armlab record"):
        realsense.open_camera(playback=tmp_path / "none.bag")
    with pytest.raises(ValueError, match="arm=False"):
        make_station("real", playback=str(tmp_path / "none.bag"))

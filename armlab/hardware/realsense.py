"""The RealSense L515 through pyrealsense2, behind armlab.station.RGBDCamera.

Streams: colour 1280x720 BGR8 at 30 fps and depth 1024x768 z16 at 30 fps, the depth aligned to the colour image with
rs.align(rs.stream.color). capture() returns armlab.station.Frame: rgb (720, 1280, 3) uint8 (converted from BGR),
depth (720, 1280) float32 mm = raw * depth scale (the device reports 0.00025 m per unit) with 0 (no return) -> NaN,
timestamp in seconds (the device's colour-frame timestamp). K and dist are the colour stream's factory intrinsics
(fx, fy, ppx, ppy; Brown-Conrady k1, k2, p1, p2, k3).

capture() returns a RealFrame (a Frame with valid_depth_fraction, the share of pixels with a depth return) and warns
when less than MIN_VALID_DEPTH_FRACTION of the depth image has a return (lens covered, target nearer than 0.25 m,
or a recording without depth).

Playback: open_camera(playback=PATH) replays a recording (.bag, from `python -m armlab record`) through the same real
pipeline and rs.align, non-real-time (every recorded frame in order, none dropped), looping by default; K, dist and
the depth scale are the recorded device's. Same RealCamera object, same frames.

pyrealsense2 is imported only by import_realsense() / open_camera(); the L515 needs pyrealsense2 2.54.x (support
ended in librealsense 2.55; wheels for CPython 3.10/3.11 on x86-64 only) and the system's libusb-1.0.
"""

from __future__ import annotations

import datetime
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from armlab.camera import check_intrinsics
from armlab.hardware import HardwareUnavailable
from armlab.station.contract import Frame

__all__ = ["COLOR_SIZE", "DEPTH_SIZE", "FPS", "MIN_VALID_DEPTH_FRACTION", "import_realsense", "depth_to_mm",
           "intrinsics_matrix", "RealFrame", "RealCamera", "open_camera", "configure_streams"]

COLOR_SIZE = (1280, 720)   # (width, height) px
DEPTH_SIZE = (1024, 768)   # the L515's native depth resolution, before alignment to colour
FPS = 30
MIN_VALID_DEPTH_FRACTION = 0.5   # capture() warns below this share of depth pixels with a return

INSTALL_HINT = ("pyrealsense2 is not importable: install the last release that drives the L515 with "
                "`pip install pyrealsense2==2.54.*` (librealsense 2.55 dropped the L515; its wheels are for CPython "
                "3.10/3.11 on x86-64 and need the system's libusb-1.0: `sudo apt install libusb-1.0-0`)")


@dataclass(frozen=True)
class RealFrame(Frame):
    """A Frame (rgb, depth mm, timestamp s) with valid_depth_fraction: the share of depth pixels with a return."""

    valid_depth_fraction: float = 1.0

    @property
    def depth_ok(self) -> bool:
        """True when at least MIN_VALID_DEPTH_FRACTION of the depth image has a return."""
        return self.valid_depth_fraction >= MIN_VALID_DEPTH_FRACTION


def import_realsense() -> Any:
    """The pyrealsense2 module; raises HardwareUnavailable saying what to install when it is missing."""
    try:
        import pyrealsense2 as rs
    except ImportError as e:
        raise HardwareUnavailable(f"{INSTALL_HINT} ({e})") from e
    return rs


def depth_to_mm(raw: np.ndarray, depth_scale_m: float) -> np.ndarray:
    """Raw z16 depth (H, W) uint16 -> float32 mm (camera-frame Z); 0 (no return) -> NaN."""
    raw = np.asarray(raw)
    if raw.ndim != 2 or raw.dtype != np.uint16:
        raise ValueError(f"raw depth must be a (H, W) uint16 image, got {raw.dtype} with shape {raw.shape}")
    if not np.isfinite(depth_scale_m) or depth_scale_m <= 0:
        raise ValueError(f"depth scale must be a positive number of metres per unit, got {depth_scale_m}")
    depth = raw.astype(np.float32) * np.float32(depth_scale_m * 1000.0)
    depth[raw == 0] = np.nan
    return depth


def intrinsics_matrix(intrinsics: Any, rs: Any) -> tuple[np.ndarray, np.ndarray]:
    """(K (3, 3), dist (5,)) from a pyrealsense2 intrinsics object (fx, fy, ppx, ppy, coeffs, model).

    Warns when the model is not Brown-Conrady (or none), since armlab.camera applies Brown-Conrady distortion.
    """
    model = getattr(intrinsics, "model", None)
    if model not in (rs.distortion.brown_conrady, rs.distortion.none):
        warnings.warn(f"the colour stream reports distortion model {model}, not Brown-Conrady: its coefficients "
                      f"are used as Brown-Conrady ones; calibrate the intrinsics (armlab.calibration) instead",
                      RuntimeWarning, stacklevel=2)
    K = np.array([[intrinsics.fx, 0.0, intrinsics.ppx], [0.0, intrinsics.fy, intrinsics.ppy], [0.0, 0.0, 1.0]])
    return check_intrinsics(K, np.asarray(intrinsics.coeffs, float)[:5])


class RealCamera:
    """A started RealSense pipeline delivering aligned RGB-D frames (see the module docstring for units).

    Attributes: K (3, 3), dist (5,) factory colour intrinsics; width, height (px); depth_scale_m (m per raw unit).
    """

    def __init__(self, pipeline: Any, align: Any, depth_scale_m: float, K: np.ndarray, dist: np.ndarray,
                 width: int = COLOR_SIZE[0], height: int = COLOR_SIZE[1], timeout_ms: int = 5000):
        self._pipeline, self._align, self._timeout_ms = pipeline, align, int(timeout_ms)
        self.depth_scale_m = float(depth_scale_m)
        if not np.isfinite(self.depth_scale_m) or self.depth_scale_m <= 0:
            raise ValueError(f"depth scale must be a positive number of metres per unit, got {depth_scale_m}")
        self.K, self.dist = check_intrinsics(K, dist)
        self.width, self.height = int(width), int(height)
        self._running = True

    def capture(self) -> Frame:
        """Wait for the next frameset, align depth to colour and convert: Frame(rgb, depth mm, timestamp s)."""
        if not self._running:
            raise RuntimeError("the camera is closed")
        frames = self._align.process(self._pipeline.wait_for_frames(self._timeout_ms))
        color, depth = frames.get_color_frame(), frames.get_depth_frame()
        if not color or not depth:
            raise RuntimeError("the RealSense frameset lacks a colour or an aligned depth frame")
        bgr = np.asanyarray(color.get_data())
        raw = np.asanyarray(depth.get_data())
        shape = (self.height, self.width)
        if bgr.shape != shape + (3,) or bgr.dtype != np.uint8 or raw.shape != shape:
            raise RuntimeError(f"unexpected frame format: colour {bgr.dtype} {bgr.shape}, depth {raw.dtype} "
                               f"{raw.shape}; expected uint8 {shape + (3,)} and uint16 {shape}")
        rgb = np.ascontiguousarray(bgr[..., ::-1])
        valid = float(np.count_nonzero(raw)) / raw.size
        if valid < MIN_VALID_DEPTH_FRACTION:
            warnings.warn(f"only {100 * valid:.0f}% of the depth image has a return: is the lens covered, the scene "
                          "nearer than 0.25 m, or the recording without depth?", RuntimeWarning, stacklevel=2)
        return RealFrame(rgb=rgb, depth=depth_to_mm(raw, self.depth_scale_m),
                         timestamp=color.get_timestamp() / 1000.0, valid_depth_fraction=valid)

    def close(self) -> None:
        """Stop the pipeline (idempotent)."""
        if self._running:
            self._running = False
            self._pipeline.stop()


def configure_streams(rs: Any, config: Any, serial: str | None = None) -> None:
    """Ask for the L515's streams (colour 1280x720 BGR8, depth 1024x768 z16, 30 fps) on the given serial or any."""
    if serial is not None:
        config.enable_device(str(serial))
    config.enable_stream(rs.stream.color, COLOR_SIZE[0], COLOR_SIZE[1], rs.format.bgr8, FPS)
    config.enable_stream(rs.stream.depth, DEPTH_SIZE[0], DEPTH_SIZE[1], rs.format.z16, FPS)


def open_camera(serial: str | None = None, warmup_frames: int = 30, timeout_ms: int = 5000,
                playback: str | Path | None = None, loop: bool = True) -> RealCamera:
    """Start the L515 (the given serial, or the first device): colour 1280x720 BGR8 and depth 1024x768 z16 at
    30 fps, depth aligned to colour; drop `warmup_frames` frames while auto-exposure settles.

    playback: replay this recording instead (its recorded streams, every frame in order, from the start again at
    the end when loop is True; no warm-up). Raises FileNotFoundError when it does not exist.
    """
    rs = import_realsense()
    pipeline, config = rs.pipeline(), rs.config()
    if playback is not None:
        path = Path(playback)
        if not path.is_file():
            raise FileNotFoundError(f"no RealSense recording at {path} (make one with `python -m armlab record "
                                    f"{path.name}` on a lab machine)")
        if serial is not None:
            raise ValueError("serial selects a live camera; a recording has its own device")
        config.enable_device_from_file(str(path), repeat_playback=bool(loop))
        config.enable_stream(rs.stream.color)
        config.enable_stream(rs.stream.depth)
        warmup_frames = 0
    else:
        configure_streams(rs, config, serial)
    profile = pipeline.start(config)
    try:
        if playback is not None:
            # Frame by frame, from the first: the pipeline starts playing in real time, so without the seek a
            # loaded machine would begin a few frames in (seen: the first capture at 1.033 s instead of 1.0 s).
            player = profile.get_device().as_playback()
            player.set_real_time(False)
            player.seek(datetime.timedelta(0))
        depth_scale_m = profile.get_device().first_depth_sensor().get_depth_scale()
        intrinsics = profile.get_stream(rs.stream.color).as_video_stream_profile().get_intrinsics()
        K, dist = intrinsics_matrix(intrinsics, rs)
        camera = RealCamera(pipeline, rs.align(rs.stream.color), depth_scale_m, K, dist,
                            intrinsics.width, intrinsics.height, timeout_ms)
        for _ in range(max(0, int(warmup_frames))):
            pipeline.wait_for_frames(timeout_ms)
    except BaseException:
        pipeline.stop()
        raise
    return camera

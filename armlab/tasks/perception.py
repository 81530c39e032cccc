"""Perception for the task layer: calibrate a station's camera and see the board with the arm out of the way.

calibrate_camera(station): intrinsics (station_intrinsics: a checkerboard set captured with THIS station's camera,
through armlab.calibration.calibrate_intrinsics; or the device's factory values; or given K, dist), then with the arm
in the camera-clear pose (armlab.planning.plan_camera_clear) one frame: AprilTag extrinsics
(calibration.calibrate_extrinsics) and the planar depth correction (calibration.fit_depth_correction, arm pixels
excluded). The result is an armlab.calibration.Calibration (save/load it with calibration.save_calibration /
load_calibration).
observe(station, calibration): arm camera-clear (clear_view: with a lower clearance or a lift back first when needed),
capture, correct the depth, detect the blocks (detection.detect_blocks with the arm masked out; or every object,
distractors included, with all_objects=True). surface_point(...): the world point (mm) under a pixel, from the median
corrected depth in a small window. Units: px, mm, rad; world (board) frame.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from armlab import calibration, detection, planning
from armlab._paths import data_path
from armlab.calibration import Calibration
from armlab.camera import Camera
from armlab.kinematics import Unreachable
from armlab.station.contract import Frame, Station

from . import executor

__all__ = ["Observation", "calibrate_camera", "clear_view", "observe", "surface_point", "pointed_point",
           "checkerboard_intrinsics", "station_intrinsics", "CLEAR_VIEW_MIN_CLEARANCE_MM", "REAL_CHECKERBOARD_FOLDER"]

CLEAR_VIEW_MIN_CLEARANCE_MM = 25.0   # tool point above what it passes on the way out of view: the finger tips
                                     # (GRIPPER.fingertip_mm = 8 mm beyond the tool point) keep 17 mm
REAL_CHECKERBOARD_FOLDER = "checkerboard_real"   # the real camera's checkerboard set, in the data folder


@dataclass(frozen=True)
class Observation:
    """One look at the board: the frame, its corrected depth (H, W) mm, the detections (the blocks, or every object
    when looked with all_objects=True) and the arm's joints."""

    frame: Frame
    depth: np.ndarray
    blocks: list
    arm_q: np.ndarray


def checkerboard_intrinsics(folder=None, image_size: tuple[int, int] | None = None) -> tuple[np.ndarray, np.ndarray]:
    """K (3, 3) and dist (5,) calibrated from a saved checkerboard set (calibration.load_checkerboard_set; default
    data/checkerboard, the simulated seed-0 camera's set). image_size: the (width, height) px the set must have."""
    folder = Path(folder) if folder is not None else data_path("checkerboard")
    images, meta = calibration.load_checkerboard_set(folder)
    if image_size is not None and tuple(meta["image_size"]) != tuple(image_size):
        raise ValueError(f"{folder}: the checkerboard views are {meta['image_size'][0]}x{meta['image_size'][1]} px, "
                         f"the camera's images {image_size[0]}x{image_size[1]}: this set is from another camera mode")
    result = calibration.calibrate_intrinsics(images, tuple(meta["pattern_size"]), float(meta["square_mm"]))
    return result.K, result.dist


def station_intrinsics(station: Station, folder=None) -> tuple[np.ndarray, np.ndarray]:
    """K (3, 3) and dist (5,) of the station's own camera, from a checkerboard set captured with THAT camera (cameras
    differ by ~0.3 % in focal length and ~4 px in principal point: another camera's K misplaces the camera by mm).

    folder: a saved set (calibration.save_checkerboard_set) to use. Without it, a station that can photograph a
    checkerboard itself does (Capabilities.camera_intrinsics: the simulator's, ~1.5 s once per camera, cached),
    and any other station reads data/checkerboard_real/ ($ARMLAB_DATA/checkerboard_real when set), the set saved from
    its camera. Raises ValueError naming the folder when the set is missing or is not of the camera's image size.
    """
    size = (station.camera.width, station.camera.height)
    if folder is None and station.capabilities.camera_intrinsics is not None:
        return station.capabilities.camera_intrinsics()
    path = Path(folder) if folder is not None else data_path(REAL_CHECKERBOARD_FOLDER)
    if not path.is_dir():
        raise ValueError(f"{path}: no checkerboard set for this camera. Photograph a checkerboard in ~16 poses with it "
                         f"and save them there with armlab.calibration.save_checkerboard_set (see its module notes)")
    return checkerboard_intrinsics(path, size)


def clear_view(mover, obstacles=(), held_below: float = 0.0) -> None:
    """Move the arm to the camera-clear pose (planning.plan_camera_clear) unless it is already there, through the
    executor (tasks.executor: checked whole first, with what is held). mover: a task Session (its held block and
    known blocks are checked), or an arm alone (a GuardedArm or a backend's Arm: what it says it holds is checked).
    obstacles: what the move passes over; held_below: how far a held block hangs below the tool point (mm).

    When the move from a low hover point would pass closer than the default clearance over a neighbour, a smaller
    clearance that still keeps the finger tips above it (CLEAR_VIEW_MIN_CLEARANCE_MM) is tried, then the arm is first
    lifted back (shoulder back by 0.3 or 0.6 rad, which raises the tool over the board; kept
    planning.LIMIT_MARGIN_RAD inside the joint limits); a way the whole-plan check refuses is passed over too. Raises
    Unreachable when no way is planned, else the last refusal (PlanRefused); nothing moves then.
    """
    runner = executor.runner(mover)
    arm = runner.arm
    q = np.asarray(arm.joint_positions(), dtype=float)
    if np.abs(q - planning.CAMERA_CLEAR_POSE).max() < 0.02:
        return
    inner = planning.inner_limits(arm.robot)
    lifts = [None] + [np.clip(q - [0.0, d, 0.0, 0.0, 0.0], inner.lower, inner.upper) for d in (0.3, 0.6)]
    refused: executor.PlanRefused | None = None
    for q_up in lifts:
        for clearance in (planning.DEFAULT_CLEARANCE_MM, CLEAR_VIEW_MIN_CLEARANCE_MM):
            try:
                plan = planning.plan_camera_clear(q if q_up is None else q_up, obstacles, clearance=clearance,
                                                  held_below=held_below)
            except Unreachable:
                continue
            if q_up is not None:
                plan = planning.Plan((planning.MoveStep(planning.joint_move(q, q_up), "lift back"),)).then(plan)
            try:
                executor.run(runner, plan, "moving out of the camera's view")
            except executor.PlanRefused as e:
                refused = e
                continue
            return
    if refused is not None:
        raise refused
    raise Unreachable("cannot move the arm out of the camera's view without passing too low over a block")


def calibrate_camera(station: Station, intrinsics="checkerboard", arm=None) -> Calibration:
    """Calibrate the station's camera (see the module notes).

    intrinsics: "checkerboard" (station_intrinsics: the station camera's own checkerboard set), "factory"
        (station.camera.K, dist) or a (K, dist) pair.
    arm: what moves the arm out of view (clear_view's mover: a task Session, or an arm; default station.arm).
    Raises ValueError when the tags are not seen or the board has too little depth.
    """
    if isinstance(intrinsics, str):
        if intrinsics == "checkerboard":
            K, dist = station_intrinsics(station)
        elif intrinsics == "factory":
            K, dist = station.camera.K, station.camera.dist
        else:
            raise ValueError(f"intrinsics must be 'checkerboard', 'factory' or (K, dist), got {intrinsics!r}")
    else:
        K, dist = intrinsics
    runner = executor.runner(arm or station.arm)
    clear_view(runner)
    frame = station.camera.capture()
    ext = calibration.calibrate_extrinsics(frame.rgb, K, dist)
    camera = Camera(K, dist, ext.T_cam_world, frame.rgb.shape[1], frame.rgb.shape[0])
    exclude = detection.arm_mask(camera, np.asarray(runner.arm.joint_positions(), float))
    correction = calibration.fit_depth_correction(frame.depth, camera, exclude=exclude)
    return Calibration(camera, correction, notes=f"tags {ext.tag_ids}, reprojection {ext.rms_px:.2f} px, depth "
                                                 f"residual {correction.residual_mm:.1f} mm")


def observe(station: Station, calib: Calibration, arm=None, obstacles=(), clear: bool = True, held_below: float = 0.0,
            all_objects: bool = False, settings: detection.DetectionSettings | None = None) -> Observation:
    """Move the arm out of view (clear_view, unless clear=False), capture a frame, correct its depth and detect.
    arm: clear_view's mover (a task Session, or an arm; default station.arm).

    Observation.blocks holds the cubes (detection.detect_blocks) or, with all_objects, every object's top face
    (detection.detect_objects: distractors included, e.g. for plans that must avoid them). settings: the detector's
    (default detection.DetectionSettings()).
    """
    runner = executor.runner(arm or station.arm)
    if clear:
        clear_view(runner, obstacles, held_below)
    frame = station.camera.capture()
    depth = calib.depth_correction.apply(frame.depth)
    q = np.asarray(runner.arm.joint_positions(), dtype=float)
    detect = detection.detect_objects if all_objects else detection.detect_blocks
    return Observation(frame, depth, detect(frame.rgb, depth, calib.camera, arm_q=q, settings=settings), q)


def surface_point(calib: Calibration, depth: np.ndarray, uv, radius: int = 3,
                  band_mm: float | None = None) -> np.ndarray:
    """World point (3,) mm of the surface seen at pixel uv = (u, v) of a corrected depth image (H, W) mm: the median
    depth of the (2 radius + 1)^2 window around it. With band_mm, only the returns of the window within band_mm of
    the centre's surface (the median of its 7 x 7 core) count: a wide window then averages the sensor's noise without
    mixing in a block's side or the board beside a block top. Raises ValueError when the pixel is outside the image
    or the window has no depth."""
    uv = np.asarray(uv, dtype=float)
    if uv.shape != (2,) or not np.all(np.isfinite(uv)):
        raise ValueError(f"a pixel is (u, v): two finite numbers, got {uv!r}")
    h, w = depth.shape
    u, v = int(round(uv[0])), int(round(uv[1]))
    if not (0 <= u < w and 0 <= v < h):
        raise ValueError(f"pixel ({uv[0]:.1f}, {uv[1]:.1f}) is outside the {w}x{h} image")
    core = depth[max(0, v - 3):v + 4, max(0, u - 3):u + 4] if band_mm is not None else None
    window = depth[max(0, v - radius):v + radius + 1, max(0, u - radius):u + radius + 1]
    if not np.isfinite(window if core is None else core).any():
        raise ValueError(f"no depth around pixel ({u}, {v}): the camera saw no surface there")
    if core is None:
        z = float(np.nanmedian(window))
    else:
        centre = float(np.nanmedian(core))
        same = window[np.abs(window - centre) < band_mm]          # NaN compares False: left out
        z = float(np.median(same)) if same.size else centre
    return calib.camera.pixel_to_world(uv[None], np.array([z]))[0]


POINTER_RADIUS_PX = 8       # what a click acts on and what the pointer's readout shows: a 17 x 17 px window (19 mm
POINTER_BAND_MM = 8.0       # at 1 m) of the returns within 8 mm of the centre's surface (a block is 25 mm or more)


def pointed_point(calib: Calibration, depth: np.ndarray, uv) -> np.ndarray:
    """The one rule for the world point (3,) mm under a pointer at pixel uv: what a click acts on (tasks.click_world)
    and what the control station's mouse-over readout shows. surface_point over a POINTER_RADIUS_PX window, keeping
    the returns within POINTER_BAND_MM of the centre's surface: the sensor's noise (about 4 mm a pixel) averages
    out over a few hundred pixels."""
    return surface_point(calib, depth, uv, radius=POINTER_RADIUS_PX, band_mm=POINTER_BAND_MM)

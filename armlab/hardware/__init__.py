"""Real-hardware backends: the Interbotix RX200 (ROS 2 Python API) and the RealSense L515 (pyrealsense2).

Nothing here imports a vendor package at import time: `import armlab.hardware` works on any machine. The vendor
modules (interbotix_xs_modules, interbotix_common_modules, rclpy, pyrealsense2) are imported only when
`make_station("real")` connects, and a missing one raises HardwareUnavailable saying what to install.

The arm is connected before the camera (a missing driver is reported before the camera is claimed). Closing the
station (Station.close(), leaving a `with` block, normally or by an exception, Ctrl+C, interpreter exit through
atexit, or a SIGTERM to the process: armlab.hardware.sigterm) puts the arm in its sleep pose, then stops the camera.
ROS stays up for the next station of the process and shuts down at exit (armlab.hardware.ros_session). While a real
station with an arm is open, Ctrl+C holds the arm, then raises KeyboardInterrupt (armlab.station.interrupt).

`make_station("real", arm=False, playback="session.bag")` replays a recording (`python -m armlab record`) through the
real librealsense pipeline instead of a camera.
"""

from __future__ import annotations

import atexit

from armlab.station.contract import Station

__all__ = ["HardwareUnavailable", "make_real_station"]


class HardwareUnavailable(ImportError):
    """A vendor package the real station needs is not importable; the message says what to install."""


def make_real_station(arm: bool = True, camera: bool = True, robot_model: str = "rx200",
                      robot_name: str | None = None, gripper_pressure: float = 0.5,
                      board_margin_mm: float | None = None, serial: str | None = None,
                      warmup_frames: int | None = None, playback: str | None = None,
                      driver_timeout_s: float | None = None) -> Station:
    """Connect the real lab: an RX200 through the Interbotix ROS 2 API and a RealSense L515.

    Args:
        arm, camera: which devices to connect (the other is None), e.g. camera=False to drive the arm alone.
        robot_model: must be "rx200" (the only arm the kit models). robot_name: the driver's namespace if not the
            model name. gripper_pressure: 0..1, the manufacturer's grasp effort fraction.
        board_margin_mm: how far above the board (mm) every joint and the tool point must stay along a move
            (default armlab.hardware.safety.DEFAULT_BOARD_MARGIN_MM).
        serial: the camera's serial number when several RealSense devices are connected.
        warmup_frames: frames dropped at start while auto-exposure settles (default 30; none in playback).
        playback: a RealSense recording (.bag, from `python -m armlab record`) to replay instead of the camera;
            needs arm=False.
        driver_timeout_s: how long to wait for the xs_sdk driver to answer (default ros_session.DRIVER_TIMEOUT_S),
            and, at least ros_session.MIN_CONNECT_S, for the Interbotix API to connect to it.

    Raises HardwareUnavailable (an ImportError) naming what to install when a vendor package is missing, before
    anything is connected; armlab.hardware.ros_session.DriverNotFound when the arm's driver does not answer (or
    stops answering while the Interbotix API connects: ROS is then shut down, restart the Python process).
    """
    from armlab.hardware import interbotix, realsense
    from armlab.hardware.ros_session import shutdown_session
    from armlab.hardware.sigterm import install_sigterm
    from armlab.station.interrupt import install_sigint

    if robot_model != "rx200":
        raise ValueError(f"robot_model {robot_model!r} is not supported: armlab models the 'rx200' only")
    if playback is not None and arm:
        raise ValueError("playback replays a recorded camera: use make_station('real', arm=False, playback=...)")
    if not (arm or camera):
        raise ValueError("make_real_station needs arm=True or camera=True")
    problems = []
    for wanted, importer in ((arm, interbotix.import_interbotix), (camera, realsense.import_realsense)):
        if wanted:
            try:
                importer()
            except HardwareUnavailable as e:
                problems.append(str(e))
    if problems:
        raise HardwareUnavailable("make_station('real') cannot start:\n- " + "\n- ".join(problems))

    real_arm, arm_closer = None, None
    restore_signals = []
    if arm:
        options = {} if board_margin_mm is None else {"board_margin_mm": board_margin_mm}
        if driver_timeout_s is not None:
            options["driver_timeout_s"] = driver_timeout_s
        real_arm, arm_closer = interbotix.connect_arm(robot_name=robot_name, gripper_pressure=gripper_pressure,
                                                      **options)
        restore_signals.append(install_sigint(real_arm.hold))
    cam = None
    if camera:
        options = {} if warmup_frames is None else {"warmup_frames": warmup_frames}
        try:
            cam = realsense.open_camera(serial=serial, playback=playback, **options)
        except BaseException:
            for restore in restore_signals:
                restore()
            if arm_closer is not None:
                arm_closer()
            raise

    station = Station("real", real_arm, cam)

    def close() -> None:
        atexit.unregister(station.close)
        for restore in restore_signals:
            restore()
        try:
            if arm_closer is not None:
                arm_closer()          # sleep pose; ROS stays up for the next station
        finally:
            if cam is not None:
                cam.close()

    def close_and_end_ros() -> None:          # SIGTERM: the process is ending
        try:
            station.close()
        finally:
            shutdown_session()

    if real_arm is not None:
        restore_signals.append(install_sigterm(close_and_end_ros))
    station._closer = close
    atexit.register(station.close)
    return station

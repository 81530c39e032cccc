"""Real-hardware backends: the Interbotix RX200 (ROS 2 Python API) and the RealSense L515 (pyrealsense2).

Nothing here imports a vendor package at import time: `import armlab.hardware` works on any machine. The vendor
modules (interbotix_xs_modules, interbotix_common_modules, pyrealsense2) are imported only when
`make_station("real")` connects, and a missing one raises HardwareUnavailable saying what to install.

Closing the station (Station.close(), leaving a `with` block, normally or by an exception, interpreter exit
through atexit, or a SIGTERM to the process: armlab.hardware.sigterm) puts the arm in its sleep pose BEFORE
robot_shutdown(), then stops the camera. The SIGTERM handler exists only while a real station with an arm is open.
"""

from __future__ import annotations

import atexit

from armlab.station import Station

__all__ = ["HardwareUnavailable", "make_real_station"]


class HardwareUnavailable(ImportError):
    """A vendor package the real station needs is not importable; the message says what to install."""


def make_real_station(arm: bool = True, camera: bool = True, robot_model: str = "rx200",
                      robot_name: str | None = None, gripper_pressure: float = 0.5,
                      board_margin_mm: float | None = None, serial: str | None = None,
                      warmup_frames: int | None = None) -> Station:
    """Connect the real lab: an RX200 through the Interbotix ROS 2 API and a RealSense L515.

    Args:
        arm, camera: which devices to connect (the other is None), e.g. camera=False to drive the arm alone.
        robot_model: must be "rx200" (the only arm the kit models). robot_name: the driver's namespace if not the
            model name. gripper_pressure: 0..1, the manufacturer's grasp effort fraction.
        board_margin_mm: how far above the board (mm) every joint and the tool point must stay along a move
            (default armlab.hardware.safety.DEFAULT_BOARD_MARGIN_MM).
        serial: the camera's serial number when several RealSense devices are connected.
        warmup_frames: frames dropped at start while auto-exposure settles (default 30).

    Raises HardwareUnavailable (an ImportError) naming what to install when a vendor package is missing, before
    anything is connected.
    """
    from armlab.hardware import interbotix, realsense
    from armlab.hardware.sigterm import install_sigterm

    if robot_model != "rx200":
        raise ValueError(f"robot_model {robot_model!r} is not supported: armlab models the 'rx200' only")
    problems = []
    for wanted, importer in ((arm, interbotix.import_interbotix), (camera, realsense.import_realsense)):
        if wanted:
            try:
                importer()
            except HardwareUnavailable as e:
                problems.append(str(e))
    if problems:
        raise HardwareUnavailable("make_station('real') cannot start:\n- " + "\n- ".join(problems))
    if not (arm or camera):
        raise ValueError("make_real_station needs arm=True or camera=True")

    cam = None
    if camera:
        cam = realsense.open_camera(serial=serial, **({} if warmup_frames is None else
                                                       {"warmup_frames": warmup_frames}))
    real_arm, arm_closer = None, None
    if arm:
        try:
            options = {} if board_margin_mm is None else {"board_margin_mm": board_margin_mm}
            real_arm, arm_closer = interbotix.connect_arm(robot_name=robot_name, gripper_pressure=gripper_pressure,
                                                          **options)
        except BaseException:
            if cam is not None:
                cam.close()
            raise

    station = Station("real", real_arm, cam)
    restore_sigterm = install_sigterm(station.close) if real_arm is not None else (lambda: None)

    def close() -> None:
        atexit.unregister(station.close)
        restore_sigterm()
        try:
            if arm_closer is not None:
                arm_closer()          # sleep pose, then robot_shutdown()
        finally:
            if cam is not None:
                cam.close()

    station._closer = close
    atexit.register(station.close)
    return station

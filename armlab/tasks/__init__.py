"""The station's behaviours: perception to action, pick and place, click-to-grab/drop, the state machine, teach
and repeat. Everything works the same on make_station("sim") and make_station("real"). Units: mm, rad, s.

Start a session first; every behaviour takes it:

    session = tasks.start_session(station)   # calibrates the camera, fits the sag model (moves the arm)
    block = tasks.look(session).blocks[0]
    tasks.pick(session, block)
"""

from . import teach
from .click import ClickRefused, click_drop, click_grab, click_with, click_world, current_view
from .guard import GuardedArm
from .handling import RELEASE_GAP_MM, look, pick, place, put_back
from .machine import STATES, MachineBusy, TaskMachine
from .perception import Observation, calibrate_camera, clear_view, surface_point
from .sag import LAB_BASELINE, SagModel, calibration_poses, fit_sag
from .session import Session, calibrate_sag, start_session
from .teach import TeachFileError, TeachProgram, load_teach, plot_teach, repeat, save_teach

__all__ = ["teach", "ClickRefused", "click_drop", "click_grab", "click_with", "click_world", "current_view",
           "STATES", "MachineBusy", "TaskMachine",
           "GuardedArm", "Observation", "calibrate_camera", "clear_view", "surface_point", "RELEASE_GAP_MM",
           "Session", "start_session", "calibrate_sag", "look", "pick", "place", "put_back", "LAB_BASELINE", "SagModel",
           "calibration_poses", "fit_sag", "TeachProgram", "TeachFileError", "load_teach", "save_teach",
           "repeat", "plot_teach"]

_MOVED_TO_UI = ("ClickResult", "ClickToGrab", "StationPanel", "station_panel")


def __getattr__(name: str):
    """The GUIs live in armlab.ui; `tasks.ClickToGrab` (as notebook 05 writes it) still finds them there."""
    if name in _MOVED_TO_UI:
        import armlab.ui

        return getattr(armlab.ui, name)
    if name in ("context", "TaskContext"):
        raise AttributeError(f"armlab.tasks.{name} is gone: start a session explicitly with "
                             f"`session = tasks.start_session(station)` and pass the session to the tasks")
    raise AttributeError(f"module 'armlab.tasks' has no attribute {name!r}")

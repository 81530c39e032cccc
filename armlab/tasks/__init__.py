"""The station's behaviours: perception to action, pick and place, click-to-grab/drop, the state machine, teach
and repeat. Everything works the same on make_station("sim") and make_station("real"). Units: mm, rad, s."""

from .guard import GuardedArm
from .perception import Observation, calibrate_camera, clear_view, surface_point
from .pickplace import RELEASE_GAP_MM, TaskContext, calibrate_sag, context, look, pick, place
from .sag import LAB_BASELINE, SagModel, calibration_poses, fit_sag

__all__ = ["GuardedArm", "Observation", "calibrate_camera", "clear_view", "surface_point", "RELEASE_GAP_MM",
           "TaskContext", "calibrate_sag", "context", "look", "pick", "place", "LAB_BASELINE", "SagModel",
           "calibration_poses", "fit_sag"]

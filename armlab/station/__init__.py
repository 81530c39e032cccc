"""One switch between the simulated and the real lab: `make_station("sim")` or `make_station("real")`.

armlab.station.contract: the types every backend implements and the code above the station relies on (Arm,
RGBDCamera, Frame, Station, Capabilities, the exceptions). armlab.station.registry: the backends by name and
make_station. Both are re-exported here: `from armlab.station import make_station, Station, MotionRefused`.
"""

from armlab.station.contract import (
    Arm,
    Capabilities,
    EmergencyStopped,
    Frame,
    GroundTruth,
    MotionRefused,
    Pacing,
    RGBDCamera,
    SagReference,
    Station,
    StationClosed,
)
from armlab.station.registry import BACKENDS, STATION_MODULES_ENV, backend_names, make_station, register_backend

__all__ = ["Frame", "Arm", "RGBDCamera", "GroundTruth", "Station", "Capabilities", "Pacing", "SagReference",
           "make_station", "MotionRefused", "EmergencyStopped", "StationClosed", "BACKENDS", "backend_names",
           "register_backend", "STATION_MODULES_ENV"]

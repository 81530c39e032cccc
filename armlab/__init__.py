"""armlab: a course kit for the RX200 robot-arm lab (simulated by default, the real arm with the same code).

Public entry points: `armlab.kinematics`, `armlab.calibration`, `armlab.detection`, `armlab.tasks`,
`armlab.camera.Camera` and `armlab.make_station`. Units: mm and rad everywhere.
"""

from armlab.station import make_station

__all__ = ["make_station"]
__version__ = "0.1.0"

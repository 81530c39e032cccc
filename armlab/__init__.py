"""armlab: a course kit for the RX200 robot-arm lab (simulated by default, the real arm with the same code).

Public entry points: `armlab.kinematics`, `armlab.calibration`, `armlab.detection`, `armlab.tasks`,
`armlab.camera.Camera` and `armlab.make_station`. Units: mm and rad everywhere.
"""

from armlab.station import make_station
from armlab.station.contract import Station

__all__ = ["make_station", "station_panel"]


def station_panel(station: Station, viewer=None, **options):
    """The lab's control station in JupyterLab for a station (armlab.ui.station_panel: live camera, mouse-over
    world coordinates, click-to-grab/drop, teach/repeat, emergency stop, joint sliders, the inline 3D view)."""
    from armlab.ui.station_panel import station_panel as make

    return make(station, viewer=viewer, **options)
__version__ = "0.1.0"

"""armlab: a course kit for the RX200 robot-arm lab (simulated by default, the real arm with the same code).

Public entry points: `armlab.kinematics`, `armlab.calibration`, `armlab.detection`, `armlab.tasks`,
`armlab.camera.Camera` and `armlab.make_station`. Units: mm and rad everywhere.
"""

from armlab.station import make_station

__all__ = ["make_station", "station_panel"]


def __getattr__(name: str):
    """`armlab.station_panel` is armlab.ui.station_panel.station_panel (the lab's control station over a task
    session, tasks.start_session(station)), imported when first asked for: `import armlab` stays light."""
    if name == "station_panel":
        from armlab.ui.station_panel import station_panel

        return station_panel
    raise AttributeError(f"module 'armlab' has no attribute {name!r}")
__version__ = "0.1.0"

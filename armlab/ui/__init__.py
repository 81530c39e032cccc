"""The kit's notebook GUIs (ipywidgets), over the station's behaviours in armlab.tasks and the 3D view in armlab.viz:

    from armlab import tasks
    from armlab.ui import station_panel, ClickToGrab
    session = tasks.start_session(station)          # calibrates the camera, fits the sag model (the arm moves)
    panel = station_panel(session, viewer=viewer)   # the control station: camera, readout, buttons, E-STOP, 3D view
    panel.widget()
    ClickToGrab(session).widget()                   # click-to-grab on the camera image alone

Nothing here is needed headless: tasks work without widgets, and these modules import ipywidgets only when a widget is
built.
"""

from armlab.ui.click_widget import ClickResult, ClickToGrab
from armlab.ui.station_panel import StationPanel, station_panel

__all__ = ["ClickResult", "ClickToGrab", "StationPanel", "station_panel"]

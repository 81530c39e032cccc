"""The meshcat viewer of the lab: `Viewer` draws the RX200, the board, frames, objects, cameras and point clouds.

    from armlab.viz import Viewer
    with Viewer() as viewer:           # starts (and later stops) its own meshcat server, or joins $ARMLAB_MESHCAT_ZMQ
        print(viewer.url)              # open it in a browser, or in a notebook:
        viewer.widget()                # the live scene inline, over the kernel's connection; `viewer` alone too
        viewer.show(q, gripper_opening_mm=30)
        viewer.joint_sliders(machine=machine)   # sliders that move the arm through a tasks.TaskMachine
        viewer.save_html("scene.html")

World (board) frame, millimetres and radians everywhere.
"""

from armlab.viz.geometry import rgbd_to_point_cloud
from armlab.viz.server import ZMQ_ENV
from armlab.viz.viewer import Viewer

__all__ = ["Viewer", "rgbd_to_point_cloud", "ZMQ_ENV"]

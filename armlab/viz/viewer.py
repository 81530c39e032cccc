"""The meshcat viewer: the RX200 drawn from primitives, the board, frames, objects, the camera and point clouds.

Every public method takes world (board-frame) millimetres and radians. Inside meshcat the kit's scene hangs under one
node scaled by 1/1000, so meshcat sees metres (its camera, grid and lights assume metres). Sizes that three.js does not
scale with the node -- a point cloud's point size -- are given to meshcat in metres.

In a notebook: `viewer.widget()` (or `viewer` as a cell's last line) shows the live scene inline (meshcat's viewer in an
anywidget, fed over the kernel's connection: armlab.viz.widget); `viewer.joint_sliders(machine=machine)` gives sliders
that start from the viewer's pose, follow every later show()/animate(), and move the arm within its joint limits through
the station's state machine (a tasks.TaskMachine: refused while busy or stopped, stopped by its e-stop). close() tells
what is still open that the viewer is gone: inline views say so, sliders are disabled with a note,
and a browser tab on the server gets a grey background and a "viewer closed" sign before the server stops. Every method
is thread-safe (one lock around the server connection), so a control panel may redraw from a worker thread.
"""

from __future__ import annotations

import contextlib
import functools
import os
import threading
import warnings
import weakref
from pathlib import Path

import numpy as np
import zmq

with warnings.catch_warnings():  # meshcat 0.3.2 imports zmq.eventloop.ioloop, deprecated since pyzmq 17
    warnings.simplefilter("ignore", DeprecationWarning)
    import meshcat
    import meshcat.geometry as mg
    from meshcat.animation import Animation

from armlab import kinematics, planning
from armlab.blocks import LAB_RGB, ObjectState
from armlab.camera import Camera
from armlab.files import write_text_atomic
from armlab.lab import LabConfig, lab_config
from armlab.robot import rx200
from armlab.transforms import homogeneous
from armlab.viz import geometry as geo
from armlab.viz.scene import MirroredWindow
from armlab.viz.server import ZMQ_ENV, ServerProcess, probe, start_server

__all__ = ["Viewer", "ROOT", "DEFAULT_EYE_MM", "CLOSED_TEXT"]

ROOT = "armlab"                                  # the kit's node: /meshcat/armlab
DEFAULT_EYE_MM = (900.0, -650.0, 700.0)          # where the browser's camera starts (it looks at the world origin)
CLOSED_TEXT = "viewer closed"                    # the sign an open browser tab shows after close()
_TIMEOUT_MS = 30_000                             # a dead server raises instead of hanging forever
_CLOSE_TIMEOUT_MS = 2_000                        # ... and close() gives it less
_ARM, _JOINT, _GRIPPER, _TOOL = 0x303030, 0x606060, 0x8a8a8a, 0xd02020
_SKY = ([135 / 255, 206 / 255, 250 / 255], [25 / 255, 25 / 255, 112 / 255])   # meshcat's background (top, bottom)
_CLOSED_SKY = ([0.62, 0.62, 0.62], [0.45, 0.45, 0.45])


def _rgb_hex(rgb) -> int:
    r, g, b = (int(c) for c in rgb)
    return (r << 16) | (g << 8) | b


def _mm_to_m_root() -> np.ndarray:
    return np.diag([1e-3, 1e-3, 1e-3, 1.0])


def _lines(points_mm: np.ndarray, color: int) -> mg.LineSegments:
    return mg.LineSegments(mg.PointsGeometry(np.asarray(points_mm, np.float32).T), mg.LineBasicMaterial(color=color))


def _stop(server: ServerProcess | None) -> None:
    if server is not None:
        server.stop()


def _serialized(method):
    """Run a Viewer method under the viewer's lock (one zmq REQ socket must not be used by two threads at once),
    its drawing commands handed to the inline views as one message."""
    @functools.wraps(method)
    def locked(self, *args, **kwargs):
        with self._lock:
            if self._vis is None:
                return method(self, *args, **kwargs)
            with self._window.batch():
                return method(self, *args, **kwargs)
    return locked


class _Sprite(mg.Object):
    """A three.js Sprite (always faces the camera); its geometry is ignored by three.js."""

    _type = "Sprite"


class _SpriteMaterial(mg.GenericMaterial):
    _type = "SpriteMaterial"


def _text_sprite(text: str) -> _Sprite:
    """A sprite showing `text` (meshcat's "_text" canvas texture: 256 x 256 px, black, shrunk to fit the width)."""
    texture = mg.GenericTexture({"type": "_text", "text": text, "font_size": 40, "font_face": "sans-serif"})
    return _Sprite(mg.Box([1.0, 1.0, 1.0]), _SpriteMaterial(map=texture, transparent=True, depthTest=False))


class Viewer:
    """A meshcat viewer of the lab that owns its server.

    Viewer() connects to the server whose zmq URL is in $ARMLAB_MESHCAT_ZMQ (the shared test-session server) or else
    starts its own; close() (or leaving a `with` block) stops an owned server for sure and removes the kit's scene
    from a shared one. Open `viewer.url` in a browser to watch live; save_html() writes a self-contained snapshot.

    Args:
        zmq_url: connect to this meshcat server instead (default: $ARMLAB_MESHCAT_ZMQ, else start one).
        q: initial joint angles (5,) rad (default: home).
        gripper_opening_mm: distance between the finger pads (mm).
        frames: draw the triads of kinematics.link_frames (world, DH 1..5, tool).
        lab: the lab config whose board, grid and tags are drawn (default: armlab.lab.lab_config()).
    """

    def __init__(self, zmq_url: str | None = None, *, q=None, gripper_opening_mm: float = 40.0, frames: bool = True,
                 lab: LabConfig | None = None):
        self._server: ServerProcess | None = None
        self._vis: meshcat.Visualizer | None = None
        self._animated = False
        self._lock = threading.RLock()
        self._slider_sets: list = []          # joint_sliders() boxes to keep in step with the shown pose
        self._panes: list = []                # widget() iframes to tell when the viewer closes
        url = zmq_url or os.environ.get(ZMQ_ENV) or None
        if url is None:
            self._server = start_server()
            url = self._server.zmq_url
        self._finalizer = weakref.finalize(self, _stop, self._server)
        try:
            web_url = probe(url)
            socket = zmq.Context.instance().socket(zmq.REQ)
            socket.setsockopt(zmq.LINGER, 0)
            socket.setsockopt(zmq.RCVTIMEO, _TIMEOUT_MS)
            socket.setsockopt(zmq.SNDTIMEO, _TIMEOUT_MS)
            socket.connect(url)
            self._window = MirroredWindow(socket, web_url)   # the server's tab and the inline views (widget())
            self._vis = meshcat.Visualizer(window=self._window)
            self.zmq_url, self.url = url, web_url
            self._lab = lab or lab_config()
            self._objects: dict[int, tuple] = {}
            self._root = self._vis[ROOT]
            self._root.delete()                       # a fresh scene, whatever an earlier user left behind
            self._vis[f"{ROOT}_closed"].delete()      # ... and no "viewer closed" sign of an earlier close()
            self._animated = True
            self._clear_animation()                   # meshcat keeps animations on its global /meshcat node
            self._root.set_transform(_mm_to_m_root())
            self._vis["/Grid"].set_property("visible", False)
            self._vis["/Axes"].set_property("visible", False)
            self._set_sky(self._vis, _SKY)            # an earlier viewer's close() greyed it
            self.look_from(DEFAULT_EYE_MM)
            with self._window.batch():
                self._draw_board()
                self._draw_arm(frames)
                self.q = np.array(rx200().home, dtype=float)
                self.gripper_opening_mm = float(gripper_opening_mm)
                self.show(self.q if q is None else q, gripper_opening_mm=gripper_opening_mm)
        except BaseException:
            self.close()
            raise

    # -- lifecycle ----------------------------------------------------------------------------------------------
    @property
    def owns_server(self) -> bool:
        """True when this viewer started its server (and close() stops it)."""
        return self._server is not None

    @property
    def server(self) -> ServerProcess | None:
        """The owned server process (None when connected to a shared one)."""
        return self._server

    @property
    def closed(self) -> bool:
        return self._vis is None

    def close(self) -> None:
        """Stop an owned server (kill + wait), or remove the kit's scene from a shared one. Idempotent.

        What is still open is told first: a browser tab on the server turns grey with a "viewer closed" sign (it keeps
        the last picture), inline views (widget()) say that the viewer is closed, and sliders are disabled with a note
        (moving them does nothing and raises nothing)."""
        with self._lock:
            vis, self._vis = self._vis, None
            if vis is not None:
                socket = vis.window.zmq_socket
                socket.setsockopt(zmq.RCVTIMEO, _CLOSE_TIMEOUT_MS)    # a dead server must not hold close() up
                socket.setsockopt(zmq.SNDTIMEO, _CLOSE_TIMEOUT_MS)
                alive = self._server is None or self._server.alive()
                with contextlib.suppress(zmq.ZMQError):
                    if not alive:
                        raise zmq.Again()
                    if self._server is None:
                        vis[ROOT].delete()
                        if self._animated:
                            vis.set_animation(Animation(), play=False)
                    self._farewell(vis)
                vis.window.zmq_socket.close(linger=0)
            self._finalizer()
        self._tell_widgets_closed()

    @staticmethod
    def _set_sky(vis: meshcat.Visualizer, colors) -> None:
        top, bottom = colors
        vis["/Background"].set_property("top_color", list(top))
        vis["/Background"].set_property("bottom_color", list(bottom))

    def _farewell(self, vis: meshcat.Visualizer) -> None:
        """Grey background and a camera-facing "viewer closed" sign over the board (meshcat units: metres)."""
        self._set_sky(vis, _CLOSED_SKY)
        sign = vis[f"{ROOT}_closed"]
        sign.set_object(_text_sprite(CLOSED_TEXT))
        sign.set_transform(homogeneous(None, [0.0, 0.15, 0.35]) @ np.diag([0.9, 0.9, 0.9, 1.0]))

    def _tell_widgets_closed(self) -> None:
        for pane in self._panes:
            with contextlib.suppress(Exception):
                pane.detach()
        for box in self._slider_sets:
            with contextlib.suppress(Exception):
                for child in box.children:
                    child.disabled = True
                box.note.value = "viewer closed: these sliders no longer move anything"

    def __enter__(self) -> Viewer:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def __repr__(self) -> str:
        return f"Viewer({'closed' if self.closed else self.url})"

    def _ipython_display_(self) -> None:
        """`viewer` as a cell's last line shows the live scene inline."""
        from IPython.display import display

        display(self.widget())

    # -- inline in a notebook -----------------------------------------------------------------------------------
    def widget(self, height_px: int = 420):
        """The live 3D view for a notebook or a panel: an anywidget (armlab.viz.widget.SceneView) that runs meshcat's
        own three.js viewer in the page and gets the scene over the kernel's comm channel, so it works wherever the
        notebook does (JupyterLab, Notebook 7, VS Code, a JupyterHub or Binder: only the Jupyter port is needed).
        Its text form (what a notebook that was not run shows, and what nbval compares) is one fixed line. close()
        leaves the last picture with a note saying the viewer is closed."""
        from armlab.viz.widget import SceneView

        if self._vis is None:
            raise RuntimeError("this Viewer is closed")
        pane = SceneView(self._window, height_px)
        self._panes.append(pane)
        return pane

    def _node(self, path: str) -> meshcat.Visualizer:
        if self._vis is None:
            raise RuntimeError("this Viewer is closed")
        return self._root[path]

    # -- static parts -------------------------------------------------------------------------------------------
    @_serialized
    def look_from(self, eye_mm) -> None:
        """Put the browser's camera at world point eye_mm (3,) mm, looking at the world origin with +z up."""
        eye = np.asarray(eye_mm, dtype=float)
        if eye.shape != (3,) or not np.all(np.isfinite(eye)) or np.linalg.norm(eye) < 1.0:
            raise ValueError(f"eye_mm must be a finite world point (3,) mm away from the origin, got {eye_mm!r}")
        if self._vis is None:
            raise RuntimeError("this Viewer is closed")
        x, y, z = eye / 1000.0  # meshcat's camera node is y-up: (x, y, z) in the z-up world is (x, z, -y) there
        self._vis["/Cameras/default"].set_transform(np.eye(4))
        self._vis["/Cameras/default/rotated/<object>"].set_property("position", [x, z, -y])

    def _draw_board(self) -> None:
        lab = self._lab
        (x0, x1), (y0, y1) = lab.board_x, lab.board_y
        thickness = 12.0
        plate = self._node("board/plate")
        plate.set_object(mg.Box([x1 - x0, y1 - y0, thickness]), mg.MeshLambertMaterial(color=0xd9cfb8))
        plate.set_transform(homogeneous(None, [(x0 + x1) / 2, (y0 + y1) / 2, -thickness / 2]))
        self._node("board/grid").set_object(_lines(geo.board_grid_segments(lab), 0x8c8270))
        size = lab.tags.size_mm
        for tag_id, pose in geo.tag_poses(lab).items():
            node = self._node(f"board/tags/tag_{tag_id}")
            node.set_object(mg.Box([size, size, 1.0]), mg.MeshLambertMaterial(color=0x101010))
            node.set_transform(pose)
        self._node("world_frame").set_object(mg.triad(100.0))

    def _draw_arm(self, frames: bool) -> None:
        for i, (name, radius) in enumerate(zip(geo.LINK_NAMES, geo.LINK_RADII_MM)):
            length = float(np.linalg.norm(np.diff(kinematics.joint_positions(np.zeros(5))[i:i + 2], axis=0)))
            self._node(f"arm/links/{name}").set_object(mg.Cylinder(length, radius), mg.MeshLambertMaterial(color=_ARM))
        for name, _, _ in geo.JOINT_DRUMS:
            self._node(f"arm/joints/{name}").set_object(mg.Cylinder(geo.DRUM_LENGTH_MM, geo.DRUM_RADIUS_MM),
                                                        mg.MeshLambertMaterial(color=_JOINT))
        for side in ("left_finger", "right_finger"):
            self._node(f"arm/gripper/{side}").set_object(mg.Box(geo.FINGER_SIZE_MM),
                                                         mg.MeshLambertMaterial(color=_GRIPPER))
        self._node("arm/gripper/palm").set_object(mg.Box(geo.PALM_SIZE_MM), mg.MeshLambertMaterial(color=_GRIPPER))
        self._node("arm/gripper/tool_point").set_object(mg.Sphere(6.0), mg.MeshLambertMaterial(color=_TOOL))
        if frames:
            for i in range(7):
                self._node(f"arm/frames/{geo.frame_name(i)}").set_object(mg.triad(60.0))

    # -- the arm ------------------------------------------------------------------------------------------------
    @_serialized
    def show(self, q, gripper_opening_mm: float | None = None) -> None:
        """Draw the arm at joints q (5,) rad with the finger pads gripper_opening_mm apart (default: unchanged).

        Raises ValueError (and draws nothing) for a wrong shape, NaN, a joint outside its limits or a bad opening.
        """
        opening = self.gripper_opening_mm if gripper_opening_mm is None else gripper_opening_mm
        q = np.asarray(q, dtype=float)
        if q.shape != (5,):
            raise ValueError(f"show takes one joint vector (5,) rad, got shape {q.shape}; use animate for a trajectory")
        parts = geo.arm_part_poses(q, opening)
        arm = self._node("arm")
        self._clear_animation()  # a loaded animation would move the arm away from this pose in the browser
        for path, pose in parts.poses.items():
            arm[path].set_transform(pose)
        self.q, self.gripper_opening_mm = q.copy(), float(opening)
        self._sync_sliders()

    def _clear_animation(self) -> None:
        if self._animated:
            self._vis.set_animation(Animation(), play=False)
            self._animated = False

    @_serialized
    def animate(self, times_s, qs, gripper_opening_mm=None, fps: int = 30, repetitions: int = 1,
                objects=None) -> None:
        """Load a joint trajectory as a meshcat animation (it plays in the browser and in saved snapshots).

        times_s (N,) increasing seconds from 0; qs (N, 5) rad; gripper_opening_mm one value or (N,) mm (default:
        the current opening). objects (optional): N lists of armlab.blocks.ObjectState, the objects at each key frame
        (world mm, rad): every object that appears in any of them is drawn and moves with the animation (a block
        carried by the gripper, a tower growing), and is hidden at the key frames whose list lacks it. The arm and
        the objects are left drawn as at the last key frame.
        """
        t = np.asarray(times_s, dtype=float)
        qs = np.asarray(qs, dtype=float)
        if t.ndim != 1 or len(t) < 2 or qs.shape != (len(t), 5):
            raise ValueError(f"animate needs times_s (N,) with N >= 2 and qs (N, 5); got {t.shape} and {qs.shape}")
        if not np.all(np.isfinite(t)) or t[0] < 0 or np.any(np.diff(t) <= 0):
            raise ValueError("times_s must be finite, start at or after 0 s and strictly increase")
        if int(fps) < 1 or int(repetitions) < 1:
            raise ValueError("fps and repetitions must be positive integers")
        tracks = None if objects is None else self._object_tracks(objects, len(t))
        opening = self.gripper_opening_mm if gripper_opening_mm is None else gripper_opening_mm
        parts = geo.arm_part_poses(qs, opening)
        arm = self._node("arm")
        animation = Animation(default_framerate=int(fps))
        for k, time_s in enumerate(t):
            with animation.at_frame(arm, float(time_s * fps)) as frame:
                for path, poses in parts.poses.items():
                    frame[path].set_transform(poses[k])
        self.show(qs[-1], float(np.broadcast_to(opening, len(t))[-1]))
        if tracks is not None:
            self._animate_objects(animation, t * fps, *tracks)
        self._vis.set_animation(animation, play=True, repetitions=int(repetitions))
        self._animated = True

    @staticmethod
    def _object_tracks(objects, n: int) -> tuple[list[ObjectState], list[dict[int, ObjectState]]]:
        """Validate per-key-frame object lists: (every object, its latest state; per frame {id: state})."""
        frames = list(objects)
        if len(frames) != n:
            raise ValueError(f"objects must hold one list of objects per key frame ({n}), got {len(frames)}")
        per_frame, latest = [], {}
        for k, objs in enumerate(frames):
            by_id = {}
            for o in objs:
                if not isinstance(o, ObjectState):
                    raise ValueError(f"objects[{k}] holds a {type(o).__name__}, expected armlab.blocks.ObjectState")
                if o.id in by_id:
                    raise ValueError(f"objects[{k}]: object id {o.id} appears twice")
                by_id[o.id] = o
            per_frame.append(by_id)
            latest.update(by_id)
        return list(latest.values()), per_frame

    def _animate_objects(self, animation: Animation, frame_numbers: np.ndarray, every: list[ObjectState],
                         per_frame: list[dict[int, ObjectState]]) -> None:
        """Draw every object (as at the last frame it appears in) and add its pose (and, when it is missing from
        some frames, visibility) track to the animation."""
        self.draw_objects(every)
        node = self._node("objects")
        missing = {o.id for o in every if any(o.id not in f for f in per_frame)}
        for k, frame_objs in enumerate(per_frame):
            with animation.at_frame(node, float(frame_numbers[k])) as frame:
                for o in every:
                    here = frame_objs.get(o.id)
                    if here is not None:
                        frame[str(o.id)].set_transform(geo.object_pose(here))
                    if o.id in missing:
                        frame[str(o.id)].set_property("visible", "boolean", here is not None)
        for object_id in missing:
            node[str(object_id)].set_property("visible", object_id in per_frame[-1])

    def joint_sliders(self, arm=None, machine=None):
        """ipywidgets sliders, one per joint (rad, within the joint limits), that start from the viewer's pose and
        follow it (every later show() or animate() moves them too, without moving anything back).

        Without a machine they move the drawn arm only (and a "gripper mm" slider opens the drawn fingers). With a
        machine (an armlab.tasks.TaskMachine) they move its station's arm, every move through the machine and so
        through its session's one executor (the whole plan checked first, with what the arm holds): the viewer first
        shows the arm's reading, each released slider moves the ARM there (a refused move, e.g. into the board, is
        reported under the sliders and they return to the arm's pose), never during another command or after an
        emergency stop, and machine.estop() stops it; the gripper is an open/close toggle. A bare arm (arm=) is
        refused with a TypeError naming the machine: no slider moves the arm around the executor. Blocking moves run
        in the kernel: for an emergency stop during motions, use the station panel (armlab.ui.station_panel), whose
        sliders always go through its machine. After close() the sliders are disabled with a note. Returns a VBox
        (attributes sliders, gripper, note); display it in a live notebook."""
        import ipywidgets as widgets

        robot = rx200()
        lo, hi = np.asarray(robot.lower, float), np.asarray(robot.upper, float)
        if arm is not None and machine is None:
            raise TypeError("joint_sliders: the arm moves only through a state machine and its session's executor: "
                            "joint_sliders(machine=tasks.TaskMachine(session)), session = tasks.start_session(station)")
        if machine is not None:
            if arm is not None and arm is not machine.station.arm:
                raise ValueError("joint_sliders: give the machine alone (its station's arm is the one moved)")
            arm = machine.station.arm
        if arm is not None:
            self.show(np.clip(np.asarray(arm.joint_positions(), float), lo, hi),
                      getattr(arm, "gripper_opening_mm", None))
        sliders = [widgets.FloatSlider(value=float(v), min=float(a), max=float(b), step=0.01, description=name,
                                       readout_format=".2f", continuous_update=arm is None)
                   for name, v, a, b in zip(robot.joint_names, self.q, lo, hi)]
        if arm is None:
            gripper = widgets.FloatSlider(value=self.gripper_opening_mm, min=0.0, max=geo.MAX_GRIPPER_OPENING_MM,
                                          step=1.0, description="gripper mm", readout_format=".0f",
                                          continuous_update=True)
        else:
            gripper = widgets.ToggleButtons(options=["open", "closed"], value="open", description="gripper")
        note = widgets.Label(value="")
        viewer_ref = weakref.ref(self)

        def update(_change=None):
            viewer = viewer_ref()
            if viewer is None or viewer.closed or box.syncing:
                return
            q = np.array([s.value for s in sliders])
            if arm is None:
                viewer.show(q, gripper.value)
                return
            try:
                if machine.state != "idle":
                    raise RuntimeError(f"the machine is in {machine.state!r}" + (
                        " (emergency-stopped: reset it first)" if machine.state == "estop" else ""))
                if _change is not None and _change["owner"] is gripper:
                    step = planning.GripperStep("close" if gripper.value == "closed" else "open", "sliders")
                else:
                    here = np.clip(np.asarray(arm.joint_positions(), float), lo, hi)
                    step = planning.MoveStep(planning.joint_move(here, q, robot=robot), "sliders")
                machine.execute(planning.Plan((step,)))
                note.value = ""
            except Exception as e:   # a refused or stopped move: say why, never raise into the widget's comm
                note.value = f"not moved: {type(e).__name__}: {str(e).splitlines()[0][:160]}"
            viewer.show(np.clip(np.asarray(arm.joint_positions(), float), lo, hi),
                        getattr(arm, "gripper_opening_mm", None))

        for s in [*sliders, gripper]:
            s.observe(update, names="value")

        class JointSliders(widgets.VBox):
            def __repr__(self) -> str:  # short and deterministic: nbval compares a displayed widget's text
                names = ", ".join(c.description for c in [*self.sliders, self.gripper])
                return f"JointSliders({names}): run the cell to use them"

        box = JointSliders([*sliders, gripper, note])
        box.sliders, box.gripper, box.note, box.syncing, box.arm = sliders, gripper, note, False, arm
        self._slider_sets.append(box)
        return box

    def _sync_sliders(self) -> None:
        """Set every slider set to the shown pose (their observers see box.syncing and move nothing)."""
        for box in self._slider_sets:
            box.syncing = True
            try:
                for s, v in zip(box.sliders, self.q):
                    s.value = float(np.clip(v, s.min, s.max))
                if box.arm is None:
                    box.gripper.value = float(np.clip(self.gripper_opening_mm, 0.0, geo.MAX_GRIPPER_OPENING_MM))
            finally:
                box.syncing = False

    # -- the station --------------------------------------------------------------------------------------------
    @_serialized
    def draw_objects(self, objects: list[ObjectState]) -> None:
        """Draw blocks and distractors (armlab.blocks.ObjectState) in their LAB_RGB colours; objects drawn earlier
        and missing from `objects` are removed. Geometry is sent once per object; later calls only move it."""
        objects = list(objects)
        ids = [o.id for o in objects]
        if len(set(ids)) != len(ids):
            raise ValueError(f"object ids must be unique, got {ids}")
        for gone in set(self._objects) - set(ids):
            self._node(f"objects/{gone}").delete()
            del self._objects[gone]
        for obj in objects:
            node = self._node(f"objects/{obj.id}")
            key = (obj.shape, obj.edge, obj.color)
            if self._objects.get(obj.id) != key:
                vertices, faces = geo.object_mesh(obj)
                node.set_object(mg.TriangularMeshGeometry(vertices, faces),
                                mg.MeshLambertMaterial(color=_rgb_hex(LAB_RGB[obj.color])))
                self._objects[obj.id] = key
            node.set_transform(geo.object_pose(obj))

    @_serialized
    def draw_camera(self, camera: Camera, depth_mm: float | None = None, name: str = "camera") -> None:
        """Draw a camera's view frustum (centre to the image corners at depth_mm, default: the depth at which it
        sees the board centre) and its frame (x right, y down, z optical axis) at its pose."""
        if not isinstance(camera, Camera):
            raise TypeError(f"draw_camera takes an armlab.camera.Camera, got {type(camera).__name__}")
        if depth_mm is None:
            (x0, x1), (y0, y1) = self._lab.board_x, self._lab.board_y
            depth_mm = float(camera.depth_of([[(x0 + x1) / 2, (y0 + y1) / 2, 0.0]])[0])
        node = self._node(f"cameras/{name}")
        node["frustum"].set_object(_lines(geo.frustum_segments(camera, depth_mm), 0xffaa00))
        node["frame"].set_object(mg.triad(80.0))
        node["frame"].set_transform(camera.T_world_cam)

    @_serialized
    def draw_point_cloud(self, points_world, colors, name: str = "cloud", point_size_mm: float = 4.0) -> None:
        """Draw points (N, 3) world mm with colours (N, 3) uint8 RGB, each point_size_mm across; rows with NaN are
        skipped."""
        P = np.asarray(points_world, dtype=float)
        C = np.asarray(colors)
        if P.ndim != 2 or P.shape[1] != 3:
            raise ValueError(f"points_world must have shape (N, 3) (world mm), got {P.shape}")
        if C.shape != P.shape or C.dtype != np.uint8:
            raise ValueError(f"colors must be uint8 (N, 3) RGB matching the points, got {C.dtype} {C.shape}")
        if not point_size_mm > 0:
            raise ValueError(f"point_size_mm must be positive, got {point_size_mm}")
        keep = np.all(np.isfinite(P), axis=1)
        # three.js sizes points in world units without the node's scale: metres here, not the kit's millimetres
        cloud = mg.PointCloud(P[keep].T.astype(np.float32), (C[keep].T / 255.0).astype(np.float32),
                              size=float(point_size_mm) / 1000.0)
        self._node(f"clouds/{name}").set_object(cloud)

    @_serialized
    def draw_rgbd(self, rgb, depth_mm, camera: Camera, stride: int = 4, name: str = "cloud",
                  point_size_mm: float = 4.0) -> int:
        """Draw an RGB-D frame as a world point cloud (every stride-th pixel, each point point_size_mm across);
        returns the number of points."""
        points, colors = geo.rgbd_to_point_cloud(rgb, depth_mm, camera, stride)
        self.draw_point_cloud(points, colors, name=name, point_size_mm=point_size_mm)
        return len(points)

    @_serialized
    def delete(self, path: str) -> None:
        """Remove a drawn item, e.g. "objects", "cameras/camera" or "clouds/cloud"."""
        path = str(path).strip("/")
        top = path.split("/")[0]
        if top not in ("objects", "cameras", "clouds"):
            raise ValueError(f"delete: {path!r} is not a station drawing (objects/..., cameras/..., clouds/...)")
        self._node(path).delete()
        for object_id in list(self._objects):
            if path == "objects" or path == f"objects/{object_id}":
                del self._objects[object_id]

    @_serialized
    def set_visible(self, path: str, visible: bool) -> None:
        """Show or hide a part of the scene: "arm", "arm/frames", "board", "objects", "cameras", "clouds", ..."""
        path = str(path).strip("/")
        if not path:
            raise ValueError("set_visible needs a path such as 'arm' or 'board'")
        self._node(path).set_property("visible", bool(visible))

    # -- snapshots ----------------------------------------------------------------------------------------------
    @_serialized
    def static_html(self) -> str:
        """The whole scene as one self-contained HTML page (about 0.9 MB, animations included, no network)."""
        if self._vis is None:
            raise RuntimeError("this Viewer is closed")
        return self._vis.static_html()

    def save_html(self, path) -> Path:
        """Write static_html() to `path` atomically (temporary file + rename); returns the path."""
        if not Path(path).parent.is_dir():
            raise FileNotFoundError(f"save_html: folder {Path(path).parent} does not exist")
        return write_text_atomic(path, self.static_html())

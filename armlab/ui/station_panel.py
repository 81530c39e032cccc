"""The lab's control station in a notebook: one ipywidgets panel over the station's state machine.

    from armlab import tasks
    from armlab.ui import station_panel
    session = tasks.start_session(station)          # calibrates the camera, fits the sag model
    panel = station_panel(session, viewer=viewer)   # viewer: an armlab.viz.Viewer (optional)
    panel.widget()                                  # display it (last line of a cell)

The panel shows the camera (colour, depth, or colour with the last look's detections), a mouse-over readout of the
world point under the pointer (mm, through the calibrated camera and the corrected depth), what the gripper holds and
what the next click on the image will do (grab the block under it / drop the held block there), buttons for
calibrate, detect, teach (torque off; on the simulator the sliders are then the hand that poses the arm) / record
waypoint / repeat, home, sleep, a red EMERGENCY STOP and reset, joint sliders that move station.arm within its
joint limits, and (with a viewer) the live 3D view inline.

Every command goes through ONE tasks.TaskMachine (its states, its refusals, its emergency stop; see
armlab.tasks.machine), and every command that moves the arm runs on a worker thread, one at a time: the kernel's main
thread stays free, so the E-STOP button (handled there) stops a running motion at once (machine.estop() halts the
arm and the guarded arm refuses every further command). A second command while one runs is refused with a message
(clicks are never queued). After every command the view is fresh: a command that ends with a look (click-grab/drop,
detect, calibrate) shows that look; any other (repeat, home, sleep, sliders, an emergency stop) captures a new
frame, and the next click on it looks again before acting, so a click never acts on a picture of the past. The 3D
view follows the arm during motions that take real time (the real arm, or the simulator with "real-time" ticked) and
is redrawn after every command (arm, blocks: the simulator's truth or the last detections, and the point cloud of the
shown frame).

Headless (tests, nbval) the same handlers are plain calls: panel.click((u, v)), panel.mouse((u, v)),
panel.detect(), panel.repeat(), panel.estop(), ... return at once; panel.wait() waits for the running command and
returns its message. Nothing runs in the background unless asked: the live camera (a timer) and the real-time
simulator are off by default, so a notebook run is deterministic.

Same code on the simulated and the real station. What only the simulator offers is used when it is there and said
so: its world's truth for drawing the blocks (station.world), moving the arm by hand in teach mode
(station.capabilities.pose_by_hand), and real-time pacing (station.capabilities.pacing).
Units: px, mm, rad, s; world (board) frame.
"""

from __future__ import annotations

import contextlib
import html
import threading
import time
from collections.abc import Callable

import cv2
import numpy as np

from armlab import planning
from armlab.blocks import LAB_RGB, ObjectState
from armlab.lab import lab_config
from armlab.tasks.click import ClickRefused
from armlab.tasks.machine import TaskMachine
from armlab.tasks.perception import pointed_point
from armlab.tasks.session import Session, as_session
from armlab.ui.click_widget import ClickToGrab, encode_view, event_pixel, holding_text, scaled_size, view_is_current

__all__ = ["StationPanel", "station_panel", "VIEW_MODES", "depth_rgb", "depth_scale_html"]

VIEW_MODES = ("camera", "depth", "detections")
DEPTH_RANGE_MM = (850.0, 1100.0)       # the depth view's colour scale (board at ~1 m, blocks nearer)
SLIDER_STEP_RAD = 0.01                 # joint sliders: 0.01 rad a key press; a drag moves the arm on release only
FOLLOW_READOUTS_HZ = 5.0               # status and slider readouts refresh while a command runs
_LOG_LINES = 8
_JOB_WAIT_S = 600.0
# The panel's page layout (laptops down to 1280 x 720): the top row (E-STOP, reset, status) is pinned (sticky) to the
# top of the notebook's scrolling area whatever of the panel is scrolled into view. A sticky element sticks to its
# nearest scrolling ancestor, so the panel and JupyterLab's (and Notebook 7's) output area boxes holding it clip
# (overflow: clip scrolls nothing) instead of hiding or scrolling (overflow: hidden or auto makes a scroll container
# of its own, and the row would stick to that); the notebook's own scrolling area is then the one it sticks to.
_PANEL_CSS = """<style>
.armlab-station-panel, .jp-OutputArea-output:has(.armlab-station-panel),
.jp-OutputArea-child:has(.armlab-station-panel), .jp-OutputArea:has(.armlab-station-panel) {
  overflow: visible !important; overflow-x: clip !important; }
.armlab-station-panel > .armlab-top { position: sticky; top: 0; z-index: 20; padding: 4px 0;
  background: var(--jp-layout-color0, white); box-shadow: 0 2px 3px rgba(0, 0, 0, 0.15); }
.armlab-station-panel .widget-toggle-button, .armlab-station-panel .jupyter-button { padding: 0 8px; }
</style>"""


def depth_rgb(depth_mm: np.ndarray, lo: float = DEPTH_RANGE_MM[0], hi: float = DEPTH_RANGE_MM[1]) -> np.ndarray:
    """A depth image (H, W) mm as RGB uint8: viridis from lo (dark) to hi mm, black where there is no return."""
    d = np.asarray(depth_mm, dtype=float)
    if d.ndim != 2:
        raise ValueError(f"depth must be an (H, W) image in mm, got shape {d.shape}")
    scaled = np.clip((d - lo) / (hi - lo), 0.0, 1.0)
    grey = np.nan_to_num(255.0 * (1.0 - scaled), nan=0.0).astype(np.uint8)   # near = bright
    rgb = cv2.applyColorMap(grey, cv2.COLORMAP_VIRIDIS)[..., ::-1]
    rgb = np.ascontiguousarray(rgb)
    rgb[~np.isfinite(d)] = 0
    return rgb


def depth_scale_html(lo: float = DEPTH_RANGE_MM[0], hi: float = DEPTH_RANGE_MM[1], stops: int = 9) -> str:
    """The depth view's colour scale as HTML: a bar in depth_rgb's colours from lo mm (left) to hi mm (right),
    labelled in mm; black is "no return"."""
    depths = np.linspace(lo, hi, stops)
    colours = depth_rgb(depths[None, :])[0]
    gradient = ", ".join(f"rgb({r},{g},{b}) {100 * i / (stops - 1):.0f}%" for i, (r, g, b) in enumerate(colours))
    return (f"<div class='armlab-depth-scale' style='font-size:12px'><div style='height:12px;"
            f"background:linear-gradient(to right, {gradient})'></div><div style='display:flex;"
            f"justify-content:space-between'><span>{lo:.0f} mm (near)</span><span>depth</span>"
            f"<span>{hi:.0f} mm (far)</span></div><span>black: no return</span></div>")


def _draw_blocks(rgb: np.ndarray, blocks, k: float) -> np.ndarray:
    """Detections drawn on an image shown at k times the camera's size: outline, centre dot, label (12 px text)."""
    out = np.ascontiguousarray(rgb).copy()
    for b in blocks:
        bright = tuple(int(c) for c in np.clip(np.array(LAB_RGB[b.color]) * 1.8, 0, 255)) if b.shape == "cube" \
            else (255, 255, 255)
        if b.contour is not None:
            pts = np.round((np.asarray(b.contour, float) + 0.5) * k - 0.5).astype(np.int32).reshape(-1, 1, 2)
            cv2.polylines(out, [pts], True, bright, 2, cv2.LINE_AA)
        u, v = (int(round((c + 0.5) * k - 0.5)) for c in b.pixel)
        cv2.circle(out, (u, v), 3, (255, 255, 255), -1, cv2.LINE_AA)
        label = f"{b.color} {b.size}" if b.shape == "cube" else "distractor"
        for colour, thick in (((255, 255, 255), 3), ((0, 0, 0), 1)):
            cv2.putText(out, label, (u + 10, v - 10), cv2.FONT_HERSHEY_SIMPLEX, 0.45, colour, thick, cv2.LINE_AA)
    return out


def _first_line(e: BaseException) -> str:
    text = str(e).strip().splitlines()
    return f"{type(e).__name__}: {text[0] if text else ''}"


def _fmt_mm(p) -> str:
    return "(" + ", ".join(f"{x:.1f}" for x in np.asarray(p, float)) + ")"


class StationPanel:
    """The control station over a station (sim or real); see the module notes.

    Args:
        session: the task session (tasks.start_session(station): camera calibration, sag model) to drive.
        viewer: an armlab.viz.Viewer to draw into and show inline (optional).
        machine: the tasks.TaskMachine to drive (default: a new one over the session).
        scale: the camera image is shown downscaled by this factor (clicks and the mouse map back to full pixels).
        live_period_s: the live camera's refresh period (the "live" toggle; off at start).
        follow_hz: how often the 3D view follows the arm during motions that take real time.
        look: start from a fresh look (the arm moves out of the camera's view and the blocks are detected) unless
            the last look is still current; False: start from a new capture wherever the arm is.
    """

    def __init__(self, session: Session, viewer=None, machine: TaskMachine | None = None, scale: float = 0.5,
                 live_period_s: float = 0.5, follow_hz: float = 10.0, look: bool = True):
        session = as_session(session, "station_panel")
        if machine is not None and machine.session is not session:
            raise ValueError("the TaskMachine given drives another session")
        if not 0.02 <= float(live_period_s) <= 60.0:
            raise ValueError(f"live_period_s must lie in [0.02, 60] s, got {live_period_s}")
        if not 0.5 <= float(follow_hz) <= 60.0:
            raise ValueError(f"follow_hz must lie in [0.5, 60] Hz, got {follow_hz}")
        self.session, self.station = session, session.station
        station = session.station
        self.machine = machine or TaskMachine(session)
        self.viewer = viewer
        self.scale = float(scale)
        self.live_period_s, self.follow_hz = float(live_period_s), float(follow_hz)
        self.clicker = ClickToGrab(session, scale=scale, machine=self.machine)
        self.robot = station.arm.robot
        self.view_mode = "detections"
        self.messages: list[str] = []
        self.refreshes = 0                 # frames shown so far (the refresh-rate measurement counts these)
        self.last_error: BaseException | None = None
        self.last_estop_at: float | None = None
        self._lock = threading.RLock()     # the panel's own state (job, frame, widgets)
        self._job: threading.Thread | None = None
        self._job_name = ""
        self._busy = False                 # a command runs (cleared once its view, sliders and status are redrawn)
        self._job_done = threading.Event() # set after that: wait() returns only when the panel is quiet again
        self._job_done.set()
        self._recorded = 0
        self._result: str = ""
        self._live = False
        self._live_thread: threading.Thread | None = None
        self._w = None                     # the widgets, once widget() built them
        self._sync = threading.local()     # .on: this thread writes readouts, which must not act (per thread: the
        self._frame = None                 # follow thread's readouts must not swallow a change made meanwhile)
        self._depth = None                 # corrected depth of the shown frame
        self._frame_is_look = False
        if look and not view_is_current(session):
            self.machine.detect()          # start from a fresh look: the arm moves out of view, the blocks are found
        if view_is_current(session):
            self._show_look()
        else:
            self._set_frame(station.camera.capture(), is_look=False)
        self._draw_viewer(cloud=True)

    # -- what the panel knows ---------------------------------------------------------------------------------
    @property
    def busy(self) -> bool:
        """True while a command runs on the worker thread."""
        return self._busy

    @property
    def job(self) -> str:
        """The running command's name ('' when idle)."""
        return self._job_name if self.busy else ""

    @property
    def holding(self):
        """The detected Block in the gripper, or None."""
        return self.session.held

    @property
    def next_click(self) -> str:
        """What a click on the image does next: "grab" or "drop"."""
        return self.clicker.next_action

    @property
    def frame_is_look(self) -> bool:
        """True when the shown frame is the last look (arm out of view, detections current)."""
        return self._frame_is_look

    def status_text(self) -> str:
        """One line: the machine's state, what is held / what the next click does, then what runs (the command, and
        the machine's state while it runs) or that the panel is ready."""
        state = self.machine.state
        if self.busy:
            return (f"running: {self._job_name} (machine: {state if state != 'idle' else 'starting'}; E-STOP stops "
                    f"it) | {holding_text(self.session)}")
        doing = "EMERGENCY-STOPPED: press reset" if state == "estop" else "ready"
        return f"state {state} | {holding_text(self.session)} | {doing}"

    def offers_real_time(self) -> bool:
        """True when the station can switch its clock (Capabilities.pacing: a simulated station offers it)."""
        return self.station.capabilities.pacing is not None

    @property
    def real_time(self) -> bool:
        """True when motions take wall-clock time (always on a real arm)."""
        pacing = self.station.capabilities.pacing
        return True if pacing is None else bool(pacing.is_real_time())

    def set_real_time(self, on: bool) -> None:
        """Simulator only: let motions take wall-clock time (True) or run in simulated time (False). Refused
        (RuntimeError) while a command runs; ValueError on a station without the option."""
        if not self.offers_real_time():
            raise ValueError("this station has no real-time option (a real arm always moves in real time)")
        with self._lock:
            if self.busy:
                raise RuntimeError(f"cannot change the pacing while {self._job_name} runs")
            self.station.capabilities.pacing.set_real_time(bool(on))
        self._update_widgets()

    # -- the shown frame ----------------------------------------------------------------------------------------
    def _set_frame(self, frame, is_look: bool, depth=None) -> None:
        if depth is None:
            depth = self.session.calibration.depth_correction.apply(frame.depth)
        with self._lock:
            self._frame, self._depth, self._frame_is_look = frame, depth, bool(is_look)
            self.refreshes += 1
        self._update_image()

    def _show_look(self) -> None:
        obs = self.session.last
        self._set_frame(obs.frame, is_look=True, depth=obs.depth)

    def frame_size(self) -> tuple[int, int]:
        """(W, H) px of the camera frame."""
        h, w = self._frame.rgb.shape[:2]
        return w, h

    def image_size(self) -> tuple[int, int]:
        """(w, h) px of the shown (encoded) image."""
        return scaled_size(self.frame_size(), self.scale)

    def view_rgb(self, mode: str | None = None) -> np.ndarray:
        """The shown picture at the shown size (h, w, 3) uint8 in a view mode (default: the panel's): the camera's
        colour image, its depth in colour, or the colour image with the last look's detections drawn (outline,
        centre and a "colour size" label drawn at the shown size, so it stays readable)."""
        mode = self.view_mode if mode is None else mode
        if mode not in VIEW_MODES:
            raise ValueError(f"view mode must be one of {VIEW_MODES}, got {mode!r}")
        full = depth_rgb(self._depth) if mode == "depth" else self._frame.rgb
        w, h = self.image_size()
        small = cv2.resize(np.ascontiguousarray(full), (w, h), interpolation=cv2.INTER_AREA)
        if mode == "detections" and self.session.last is not None:
            small = _draw_blocks(small, self.session.last.blocks, w / full.shape[1])
        return small

    def view(self) -> tuple[bytes, tuple[int, int]]:
        """(JPEG bytes, (w, h)) of the shown picture, the last click marked."""
        marker = self.clicker.marker
        k = self.image_size()[0] / self.frame_size()[0]
        small_marker = None if marker is None else tuple((np.asarray(marker) + 0.5) * k - 0.5)
        return encode_view(self.view_rgb(), 1.0, small_marker)

    def refresh(self) -> None:
        """Capture a new frame now and show it (and redraw the 3D view). Refused while a command runs (its own
        view comes when it ends)."""
        if self.busy:
            self._log(f"refresh skipped: {self._job_name} runs (its view comes when it ends)")
            return
        self._set_frame(self.station.camera.capture(), is_look=False)
        self._draw_viewer(cloud=True)

    # -- mouse-over ---------------------------------------------------------------------------------------------
    def world_at(self, uv) -> np.ndarray:
        """The world point (3,) mm of the surface at camera pixel uv = (u, v) of the shown frame (what the mouse-over
        readout shows): the rule a click acts by (tasks.perception.pointed_point: the median corrected depth of the
        surface around the pixel, through the calibrated camera), so the point shown under the pointer is the point a
        click acts on. Raises ValueError outside the image or where the camera saw nothing."""
        return pointed_point(self.session.calibration, self._depth, np.asarray(uv, dtype=float).reshape(2))

    def mouse(self, uv) -> str:
        """The readout for the pointer at camera pixel uv = (u, v) of the shown frame: world_at(uv) in mm, or why
        there is none (shown under the image)."""
        u, v = (float(c) for c in np.asarray(uv, dtype=float).reshape(2))
        where = f"pixel ({u:.1f}, {v:.1f})"
        try:
            p = self.world_at((u, v))
        except ValueError as e:
            text = f"{where}: {e}"
        else:
            cfg = lab_config()
            note = "" if bool(cfg.on_board(p[:2])) else " (off the board)"
            text = f"{where}: world x {p[0]:.1f}, y {p[1]:.1f}, z {p[2]:.1f} mm{note}"
        if self._w is not None:
            self._w["mouse"].value = html.escape(text)
        return text

    # -- commands -----------------------------------------------------------------------------------------------
    def click(self, uv) -> bool:
        """A click on the shown frame at camera pixel uv: grab the block under it when the gripper is empty, else
        drop the held block there (runs on the worker; False when refused because a command runs)."""
        uv = tuple(float(c) for c in np.asarray(uv, dtype=float).reshape(-1))

        def act():
            if not (self._frame_is_look and view_is_current(self.session)):
                self.machine.detect()          # the shown frame is live: look (arm out of view) before acting
            result = self.clicker.click(uv, check_view=False)
            return result.message
        return self._start(f"click-{self.next_click}", act)

    def calibrate(self) -> bool:
        """Calibrate the camera again (checkerboard intrinsics, AprilTag extrinsics, depth plane), then look."""
        def act():
            calib = self.machine.calibrate()
            self.machine.detect()
            return f"calibrated: {calib.notes}" if getattr(calib, "notes", "") else "calibrated the camera"
        return self._start("calibrate", act)

    def detect(self) -> bool:
        """Look at the board (arm out of view) and detect the blocks."""
        def act():
            blocks = self.machine.detect()
            listed = ", ".join(f"{b.color} {b.size} at ({b.position[0]:.0f}, {b.position[1]:.0f}) mm" for b in blocks)
            return f"detected {len(blocks)} blocks" + (f": {listed}" if listed else "")
        return self._start("detect", act)

    def home(self) -> bool:
        """Move to the home pose (one joint move)."""
        return self.move(self.robot.home, name="home")

    def sleep(self) -> bool:
        """Move to the sleep pose (one joint move)."""
        return self.move(self.robot.sleep, name="sleep")

    def move(self, q, name: str = "move") -> bool:
        """Move the arm to joints q (5,) rad (within the limits) through the machine (one joint move, the guarded
        arm: sag compensated, stoppable). Refused (False, said in the log) while a command runs or when the machine
        is not idle (emergency-stopped, teaching): the sliders go through here too."""
        q = np.asarray(q, dtype=float)
        if q.shape != (5,) or not np.all(np.isfinite(q)):
            raise ValueError(f"move takes 5 finite joint angles (rad), got {q!r}")
        bad = self.robot.limit_violations(q)
        if bad:
            self._log("move refused, nothing moved: " + "; ".join(bad))
            self._update_widgets()
            return False
        def act():
            here = np.clip(np.asarray(self.session.arm.joint_positions(), float), self.robot.lower, self.robot.upper)
            if np.abs(here - q).max() < 1e-4:
                return f"{name}: already there"
            plan = planning.Plan((planning.MoveStep(planning.joint_move(here, q, robot=self.robot), name),))
            self.machine.execute(plan)
            return f"{name}: moved to {np.round(q, 2) + 0.0} rad in {plan.duration:.1f} s"
        return self._start(name, act)

    def teach(self) -> str:
        """Start teaching (torque off: hold the real arm first!) or, while teaching, finish (torque on); returns
        what happened."""
        if self.busy:
            return self._log(f"teach refused: {self._job_name} runs")
        try:
            if self.machine.state == "teach":
                program = self.machine.teach_finish()
                self._recorded = 0
                text = f"taught {len(program)} waypoints (repeat replays them)"
            else:
                self.machine.teach_start("panel")
                hand = " move the sliders (the simulator's hand)" if self._hand() else " pose the arm by hand"
                text = f"teaching: torque off;{hand}, then record each waypoint"
                if self._hand() is None:       # the real arm: the sliders and the 3D view follow your hand
                    threading.Thread(target=self._follow_teaching, daemon=True, name="armlab-teach").start()
        except Exception as e:
            text = f"teach refused: {_first_line(e)}"
        self._after_job()
        return self._log(text)

    def record(self, gripper: str = "open") -> str:
        """Record the arm's joints as a waypoint with the gripper state wanted there ("open" or "closed")."""
        try:
            q = self.machine.teach_record(gripper)
            self._recorded += 1
            text = f"waypoint {self._recorded} recorded: {np.round(q, 2) + 0.0} rad, gripper {gripper}"
        except Exception as e:
            text = f"record refused: {_first_line(e)}"
        return self._log(text)

    def repeat(self) -> bool:
        """Replay the taught program through the guarded arm."""
        def act():
            result = self.machine.repeat()
            return f"repeated the program: {result.steps} steps, {result.commands} commands"
        return self._start("repeat", act)

    def estop(self) -> str:
        """EMERGENCY STOP: halt the arm now (any thread, also while a command runs); everything is refused until
        reset()."""
        self.machine.estop()
        self.last_estop_at = time.monotonic()       # when the arm was told to halt (for latency measurements)
        job = self._job
        if job is not None and job.is_alive():       # a move starting at this very moment must not outlive it
            threading.Thread(target=self._hold_stopped, args=(job,), daemon=True, name="armlab-estop").start()
        text = self._log("EMERGENCY STOP: the arm is halted; press reset to go on")
        if not self.busy:
            self._after_job()
        else:
            self._update_widgets()
        return text

    def _hold_stopped(self, job: threading.Thread, period_s: float = 0.02, limit_s: float = 10.0) -> None:
        end = time.monotonic() + limit_s
        while job.is_alive() and time.monotonic() < end:
            with contextlib.suppress(Exception):
                if self.station.arm.is_moving():
                    self.station.arm.emergency_stop()
            time.sleep(period_s)

    def reset(self) -> str:
        """Leave the emergency stop (the arm stays where it stopped, torque on). Refused while the stopped command
        is still ending."""
        if self.busy:
            return self._log(f"reset refused: {self._job_name} is still ending")
        try:
            self.machine.reset()
            text = "reset: the arm holds where it stopped; ready"
        except Exception as e:
            text = f"reset failed: {_first_line(e)}"
        self._after_job()
        return self._log(text)

    def wait(self, timeout_s: float = _JOB_WAIT_S) -> str:
        """Wait for the running command (if any) to end; returns its message. TimeoutError if it does not."""
        if not self._job_done.wait(timeout_s):
            raise TimeoutError(f"{self._job_name} still runs after {timeout_s:g} s")
        return self._result

    # -- the worker -----------------------------------------------------------------------------------------------
    def _start(self, name: str, action: Callable[[], str]) -> bool:
        with self._lock:
            if self.busy:
                self._log(f"{name} refused: {self._job_name} runs (one command at a time; E-STOP works any time)")
                return False
            if self.machine.state != "idle":      # the machine would refuse it too: say so without starting
                why = "emergency-stopped: press reset first" if self.machine.state == "estop" else \
                    f"the machine is in {self.machine.state!r}"
                self._log(f"{name} refused, nothing moved: {why}")
                return False
            self._job_name, self._result = name, ""
            self._busy = True
            self._job_done.clear()
            self._job = threading.Thread(target=self._run, args=(name, action), daemon=True,
                                         name=f"armlab-panel-{name}")
        self._update_widgets()
        self._job.start()
        threading.Thread(target=self._follow, args=(self._job,), daemon=True, name="armlab-follow").start()
        return True

    def _run(self, name: str, action: Callable[[], str]) -> None:
        try:
            message = action()
        except Exception as e:      # every refusal and stop is reported, never raised into the widget comm
            self.last_error = e
            kind = "stopped" if "Stopped" in type(e).__name__ else "refused"
            message = f"{name} {kind}: {_first_line(e)}"
        try:
            self._result = message
            self._log(message)
            self._after_job(update=False)
        finally:
            with self._lock:
                self._busy = False
            self._update_widgets()
            self._job_done.set()

    def _after_job(self, update: bool = True) -> None:
        """Show a fresh view: the last look when it is current (the arm has not moved since), else a new capture;
        then redraw the 3D view (and, with update, the sliders and the status)."""
        try:
            if self.session.last is not None and view_is_current(self.session):
                self._show_look()
            else:
                self._set_frame(self.station.camera.capture(), is_look=False)
            self._draw_viewer(cloud=True)
        except Exception as e:
            self.last_error = e
            self._log(f"view not refreshed: {_first_line(e)}")
        if update:
            self._update_widgets()

    def _follow_teaching(self, period_s: float = 0.2) -> None:
        while self.machine.state == "teach":
            with contextlib.suppress(Exception):
                self._update_widgets()
                self._draw_viewer(cloud=False)
            time.sleep(period_s)

    def _follow(self, job: threading.Thread) -> None:
        """While `job` runs: the status and the slider readouts at FOLLOW_READOUTS_HZ, and (in real time) the 3D view
        at follow_hz, so that a motion that takes time is seen as it happens, not only at its end."""
        period = 1.0 / max(self.follow_hz, FOLLOW_READOUTS_HZ)
        next_readout = 0.0
        while job.is_alive():
            now = time.monotonic()
            with contextlib.suppress(Exception):
                if self.viewer is not None and self.real_time:
                    self._draw_viewer(cloud=False)
                if now >= next_readout:
                    next_readout = now + 1.0 / FOLLOW_READOUTS_HZ
                    self._update_widgets()
            time.sleep(period)

    # -- the 3D view --------------------------------------------------------------------------------------------
    def _arm_pose(self) -> np.ndarray:
        q = np.asarray(self.station.arm.joint_positions(), dtype=float)
        return np.clip(q, self.robot.lower, self.robot.upper)

    def _objects(self) -> list[ObjectState]:
        world = getattr(self.station, "world", None)
        if world is not None:                     # the simulator's truth
            return list(world.objects)
        seen = [] if self.session.last is None else self.session.last.blocks
        return [ObjectState(b.color, b.size, float(b.edge_mm), np.asarray(b.position) - [0, 0, b.edge_mm / 2],
                            float(b.yaw), id=i + 1) for i, b in enumerate(seen) if b.shape == "cube"]

    def _draw_viewer(self, cloud: bool) -> None:
        viewer = self.viewer
        if viewer is None or viewer.closed:
            return
        opening = getattr(self.station.arm, "gripper_opening_mm", None)
        viewer.show(self._arm_pose(), None if opening is None else float(np.clip(opening, 0.0, 74.0)))
        viewer.draw_objects(self._objects())
        if cloud and self._frame is not None:
            viewer.draw_rgbd(self._frame.rgb, self._depth, self.session.calibration.camera, stride=8)

    # -- messages -------------------------------------------------------------------------------------------------
    def _log(self, text: str) -> str:
        with self._lock:
            self.messages.append(text)
            del self.messages[:-50]
        self._render_log()
        return text

    def _render_log(self) -> None:
        if self._w is not None:
            lines = "\n".join(html.escape(m) for m in self.messages[-_LOG_LINES:])
            self._w["log"].value = (f"<pre class='armlab-log' style='margin:0;white-space:pre-wrap;"
                                    f"font-size:12px'>{lines}</pre>")

    def _hand(self):
        """The station's hand (Capabilities.pose_by_hand: the simulator's) when it has one."""
        return self.station.capabilities.pose_by_hand

    # -- widgets --------------------------------------------------------------------------------------------------
    def _update_image(self) -> None:
        if self._w is not None:
            data, _ = self.view()
            self._w["image"].value = data
            caption = ("the last look (arm out of view)" if self._frame_is_look else
                       "captured after the last move; the next click looks again first")
            self._w["caption"].value = f"<i>{html.escape(caption)}</i>"

    def _update_widgets(self) -> None:
        w = self._w
        if w is None:
            return
        with self._lock:
            busy, state = self.busy, self.machine.state
            self._sync.on = True      # programmatic values below must not act
            try:
                self._set_controls(w, busy, state)
            finally:
                self._sync.on = False

    def _set_controls(self, w, busy: bool, state: str) -> None:
        colour = "#c62828" if state == "estop" else ("#1565c0" if busy else "#2e7d32")
        w["status"].value = (f"<div class='armlab-status' style='font-size:14px;padding:4px 8px;color:white;"
                             f"background:{colour};border-radius:3px'><b>{html.escape(self.status_text())}</b></div>")
        for key in ("calibrate", "detect", "home", "sleep", "repeat"):
            w[key].disabled = busy or state != "idle"
        w["repeat"].disabled = w["repeat"].disabled or self.machine.program is None
        w["teach"].disabled = busy or state not in ("idle", "teach")
        w["teach"].description = "finish teaching" if state == "teach" else "teach"
        w["record"].disabled = busy or state != "teach"
        w["reset"].disabled = busy or state != "estop"
        if "real_time" in w:
            w["real_time"].disabled = busy
            w["real_time"].value = self.real_time
        self._sync_sliders()

    def _sync_sliders(self) -> None:
        """Sliders show where the arm is (also while a command moves it: they are disabled then, and set only as
        readouts); they are disabled while a command runs, when emergency-stopped, and when teaching the real arm."""
        w = self._w
        if w is None:
            return
        teaching = self.machine.state == "teach"
        q = self.station.arm.joint_positions() if teaching else self.session.arm.joint_positions()
        q = np.clip(np.asarray(q, float), self.robot.lower, self.robot.upper)
        locked = self.busy or self.machine.state not in ("idle", "teach") or (teaching and self._hand() is None)
        for s, v in zip(w["sliders"], q):
            s.value = float(v)
            s.disabled = locked

    def _syncing(self) -> bool:
        """Whether this thread is writing readouts into the widgets (a change it makes is not the user's)."""
        return getattr(self._sync, "on", False)

    def _on_slider(self, _change) -> None:
        if self._syncing():
            return
        q = np.array([s.value for s in self._w["sliders"]])
        if self.machine.state == "teach":
            hand = self._hand()
            if hand is None:
                return
            try:
                hand(q)
                self._log(f"posed by hand: {np.round(q, 2) + 0.0} rad")
            except Exception as e:
                self._log(f"the hand cannot go there: {_first_line(e)}")
            self._after_job()
            return
        if not self.move(q, name="sliders"):
            self._update_widgets()

    def _on_mouse_event(self, event) -> None:
        kind = event.get("type")
        try:
            uv = event_pixel(event, self.frame_size(), self.image_size())
        except ClickRefused as e:
            if kind == "click":
                self._log(f"click refused, nothing moved: {e}")
            return
        if kind == "mousemove":
            self.mouse(uv)
        elif kind == "click":
            self.click(uv)

    def _on_mode(self, change) -> None:
        self.view_mode = change["new"]
        self._w["depth_scale"].layout.display = "" if self.view_mode == "depth" else "none"
        self._update_image()

    def _on_live(self, change) -> None:
        self._live = bool(change["new"])
        if self._live and (self._live_thread is None or not self._live_thread.is_alive()):
            self._live_thread = threading.Thread(target=self._live_loop, daemon=True, name="armlab-live")
            self._live_thread.start()

    def _live_loop(self) -> None:
        while self._live:
            start = time.monotonic()
            if not self.busy:
                with contextlib.suppress(Exception):
                    self._set_frame(self.station.camera.capture(), is_look=False)
                    self._draw_viewer(cloud=False)
            time.sleep(max(0.0, self.live_period_s - (time.monotonic() - start)))

    def stop_live(self) -> None:
        """Stop the live camera timer (and wait for its thread)."""
        self._live = False
        if self._w is not None:
            self._w["live"].value = False
        thread = self._live_thread
        if thread is not None:
            thread.join(timeout=10.0)

    def close(self) -> None:
        """Stop the live timer and wait for a running command (an emergency stop is the caller's choice)."""
        self.stop_live()
        with contextlib.suppress(TimeoutError):
            self.wait(timeout_s=60.0)

    def widget(self):
        """The panel as an ipywidgets.VBox (its text form is one fixed line, which nbval compares). Needs
        ipywidgets and ipyevents."""
        try:
            import ipywidgets as w
            from ipyevents import Event
        except ImportError as e:
            raise ImportError(f"the station panel needs ipywidgets and ipyevents (pip install -r requirements.txt): "
                              f"{e}") from e
        button = dict(layout=w.Layout(width="150px"))
        widgets = {
            "status": w.HTML(),
            "image": w.Image(format="jpeg", layout=w.Layout(width="100%", height="auto")),
            "depth_scale": w.HTML(value=depth_scale_html(),
                                  layout=w.Layout(display="" if self.view_mode == "depth" else "none")),
            "caption": w.HTML(),
            "mouse": w.HTML(value="move the pointer over the image: world coordinates appear here"),
            "mode": w.ToggleButtons(options=list(VIEW_MODES), value=self.view_mode, description="view",
                                    style={"button_width": "auto"}, layout=w.Layout(width="auto")),  # whole labels
            "live": w.ToggleButton(value=False, description="live camera", icon="video-camera", **button),
            "refresh": w.Button(description="refresh view", icon="refresh", **button),
            "calibrate": w.Button(description="calibrate", icon="crosshairs", **button),
            "detect": w.Button(description="detect", icon="search", **button),
            "teach": w.Button(description="teach", icon="hand-paper-o", **button),
            "gripper": w.ToggleButtons(options=["open", "closed"], value="open", description="waypoint",
                                       style={"button_width": "auto"}, layout=w.Layout(width="auto")),
            "record": w.Button(description="record waypoint", icon="circle", **button),
            "repeat": w.Button(description="repeat", icon="repeat", **button),
            "home": w.Button(description="home", icon="home", **button),
            "sleep": w.Button(description="sleep", icon="bed", **button),
            "estop": w.Button(description="EMERGENCY STOP", button_style="danger", icon="stop",
                              layout=w.Layout(width="180px", height="48px", flex="0 0 auto")),
            "reset": w.Button(description="reset", icon="undo", layout=w.Layout(width="90px", height="48px",
                                                                                flex="0 0 auto")),
            "log": w.HTML(),
        }
        widgets["sliders"] = [w.FloatSlider(value=0.0, min=float(lo), max=float(hi), step=SLIDER_STEP_RAD,
                                            description=name, readout_format=".2f", continuous_update=False,
                                            style={"description_width": "96px"},   # "wrist_rotate" whole
                                            layout=w.Layout(width="100%", margin="2px 0"))   # no overflow
                              for name, lo, hi in zip(self.robot.joint_names, self.robot.lower, self.robot.upper)]
        for name in ("estop", "reset", "calibrate", "detect", "teach", "record", "repeat", "home", "sleep",
                     "refresh", "image", "mouse", "caption", "mode", "live", "gripper"):
            widgets[name].add_class(f"armlab-{name}")      # stable handles for a page (and its tests)
        for s in widgets["sliders"]:
            s.add_class("armlab-slider")
        if self.offers_real_time():
            widgets["real_time"] = w.Checkbox(value=self.real_time, description="real-time (simulator)",
                                              indent=False)
            widgets["real_time"].add_class("armlab-real-time")
            widgets["real_time"].observe(self._on_real_time, names="value")
        widgets["estop"].on_click(lambda _b: self.estop())
        widgets["reset"].on_click(lambda _b: self.reset())
        widgets["calibrate"].on_click(lambda _b: self.calibrate())
        widgets["detect"].on_click(lambda _b: self.detect())
        widgets["teach"].on_click(lambda _b: self.teach())
        widgets["record"].on_click(lambda _b: self.record(widgets["gripper"].value))
        widgets["repeat"].on_click(lambda _b: self.repeat())
        widgets["home"].on_click(lambda _b: self.home())
        widgets["sleep"].on_click(lambda _b: self.sleep())
        widgets["refresh"].on_click(lambda _b: self.refresh())
        widgets["mode"].observe(self._on_mode, names="value")
        widgets["live"].observe(self._on_live, names="value")
        for s in widgets["sliders"]:
            s.observe(self._on_slider, names="value")
        self._events = Event(source=widgets["image"], watched_events=["click", "mousemove"],
                             prevent_default_action=True, throttle_or_debounce="throttle", wait=40)
        self._events.on_dom_event(self._on_mouse_event)
        self._w = widgets
        self._update_image()
        self._render_log()
        self._update_widgets()

        # Fits 1366 x 768 with JupyterLab's file browser open (outputs about 950 px wide): the E-STOP, the status,
        # the camera and the 3D view in the first 480 px; widths in % (no horizontal scrollbar); the camera image
        # scales (clicks map through its natural pixels).
        controls = [widgets["calibrate"], widgets["detect"], widgets["home"], widgets["sleep"], widgets["teach"],
                    widgets["gripper"], widgets["record"], widgets["repeat"], widgets["refresh"], widgets["live"]]
        if "real_time" in widgets:
            controls.append(widgets["real_time"])
        flexible = dict(min_width="0", overflow="hidden")
        top = w.HBox([widgets["estop"], widgets["reset"], w.Box([widgets["status"]], layout=w.Layout(
            flex="1 1 auto", margin="0 0 0 8px", **flexible))], layout=w.Layout(width="100%", align_items="center"))
        top.add_class("armlab-top")                                # pinned (_PANEL_CSS)
        camera = w.VBox([widgets["mode"], widgets["image"], widgets["depth_scale"], widgets["caption"],
                         widgets["mouse"]], layout=w.Layout(flex="1 1 55%", **flexible))
        views = [camera]
        if self.viewer is not None and not self.viewer.closed:
            views.append(w.Box([self.viewer.widget(height_px=330)],
                               layout=w.Layout(flex="1 1 45%", margin="0 0 0 8px", **flexible)))
        parts = [w.HTML(_PANEL_CSS, layout=w.Layout(display="none")), top,
                 w.HBox(views, layout=w.Layout(width="100%", align_items="flex-start")),
                 w.HBox(controls, layout=w.Layout(width="100%", flex_flow="row wrap")),
                 w.HTML("<b>joints</b> (rad; release a slider to move the arm there; refused while a command runs)"),
                 w.VBox(widgets["sliders"], layout=w.Layout(width="100%")), widgets["log"]]

        class StationPanelBox(w.VBox):
            def __repr__(self) -> str:      # the text form nbval compares: fixed, no ids, no URLs
                return ("StationPanel(camera, world readout, click-to-grab/drop, teach/repeat, E-STOP, joints): "
                        "run the cell")

        box = StationPanelBox(parts, layout=w.Layout(width="100%"))      # overflow: _PANEL_CSS
        box.add_class("armlab-station-panel")
        return box

    def _on_real_time(self, change) -> None:
        if self._syncing():
            return
        try:
            self.set_real_time(bool(change["new"]))
            self._log(f"simulator pacing: {'real time' if change['new'] else 'simulated time (moves are instant)'}")
        except Exception as e:
            self._log(f"pacing not changed: {_first_line(e)}")
            self._update_widgets()


def station_panel(session: Session, viewer=None, **options) -> StationPanel:
    """The control station over a task session (tasks.start_session(station); see StationPanel); display
    panel.widget() in a notebook."""
    return StationPanel(session, viewer=viewer, **options)

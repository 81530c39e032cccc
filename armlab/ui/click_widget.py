"""Click on the camera image to grab a block (first click) and drop it (second click): the live notebook panel.

The panel works in a task session (tasks.start_session(station)) and shows its current camera frame
(session.last.frame, the last look at the board) as an ipywidgets.Image, downscaled by `scale` and JPEG-encoded,
and listens to its clicks with ipyevents.Event. A click
event is turned into a camera pixel (event_pixel: ipyevents reports the click in the image's own pixels, dataX/dataY,
whatever size the browser draws it at; relativeX/relativeY over the drawn size is the fallback) and handed to
ClickToGrab.click((u, v)) -- the same call a headless notebook or a test makes. A click grabs when the gripper is
empty (tasks.click_grab) and drops the held block when it is not (tasks.click_drop); every click returns a
ClickResult whose message says the world point, what the arm did (its commands and motion time) or why the click
was refused (nothing moved then). The view is refreshed after each action (click_grab/click_drop look again), and
the panel's title says what the gripper holds and what the next click will do.

A view is current while the arm has not moved since it was taken (view_is_current); widget() looks again first when
it is not (e.g. after a pick made outside the panel, whose frame still shows the block on the board), and a click
on a stale view is refused (nothing moves) after a new look, so no click ever acts on an old picture. Given a
tasks.TaskMachine, clicks run through it (its click-grab / click-drop states and its emergency stop). Given a click
sequence of one's own (exercise grab.sequence, notebook 05: on_click / after), each click runs through
tasks.click_with with it, and the sequence decides what the click means; the kit's click rule is not used.

Pixels: OpenCV convention (u right, v down, integer = pixel centre) in the camera's full-resolution frame.
Units: mm, rad, s; world (board) frame. ipywidgets and ipyevents are imported only by ClickToGrab.widget().
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

import cv2
import numpy as np

from armlab.station.contract import EmergencyStopped, MotionRefused
from armlab.tasks.click import ClickRefused, click_drop, click_grab, click_with, click_world, current_view
from armlab.tasks.handling import look
from armlab.tasks.machine import MachineBusy
from armlab.tasks.session import Session, as_session

__all__ = ["ClickResult", "ClickToGrab", "event_pixel", "encode_view", "scaled_size", "view_is_current",
           "holding_text", "STALE_VIEW_RAD"]

MARKER_RGB = (255, 0, 255)     # the last click, drawn on the shown frame
STALE_VIEW_RAD = 0.02          # a look is out of date once any joint has moved more than this since it was taken


def view_is_current(session: Session) -> bool:
    """True when the session has a last look (session.last) and the arm has not moved since it was taken (every
    joint within STALE_VIEW_RAD of the look's reading): the frame then shows the board as it is."""
    session = as_session(session, "view_is_current")
    if session.last is None:
        return False
    moved = np.abs(np.asarray(session.arm.joint_positions(), float) - np.asarray(session.last.arm_q, float)).max()
    return bool(moved <= STALE_VIEW_RAD)


def holding_text(session: Session) -> str:
    """What the gripper holds and what the next click does, in one line."""
    held = as_session(session, "holding_text").held
    if held is None:
        return "holding nothing: the next click grabs the block under it"
    return f"holding the {held.color} {held.size} block: the next click drops it where you click"


def event_pixel(event: Mapping, frame_size: tuple[int, int], image_size: tuple[int, int]) -> tuple[float, float]:
    """Camera pixel (u, v) of an ipyevents mouse event on an image of image_size = (w, h) px (the encoded image)
    that shows a camera frame of frame_size = (W, H) px.

    ipyevents puts the click in the image's natural pixels in dataX/dataY (it divides the offset inside the image by
    the drawn width and multiplies by the natural width, so the drawn size does not matter); without them the click
    is relativeX/relativeY over the drawn boundingRectWidth/Height (no border or padding assumed). The browser
    measures from the image's top-left corner, OpenCV from the centre of the top-left pixel: u = x * W / w - 0.5.
    Raises ClickRefused when the event has no position or lies outside the image.
    """
    W, H = (int(s) for s in frame_size)
    w, h = (int(s) for s in image_size)
    if min(W, H, w, h) <= 0:
        raise ValueError(f"frame_size {frame_size} and image_size {image_size} must be positive (width, height) px")
    if "dataX" in event and "dataY" in event:
        x, y = float(event["dataX"]) / w, float(event["dataY"]) / h
    elif {"relativeX", "relativeY", "boundingRectWidth", "boundingRectHeight"} <= event.keys():
        bw, bh = float(event["boundingRectWidth"]), float(event["boundingRectHeight"])
        if bw <= 0 or bh <= 0:
            raise ClickRefused(f"the image is drawn {bw:g} x {bh:g} px: no click position")
        x, y = float(event["relativeX"]) / bw, float(event["relativeY"]) / bh
    else:
        raise ClickRefused(f"the {event.get('type', 'unknown')!r} event carries no position (need dataX/dataY or "
                           f"relativeX/relativeY with boundingRectWidth/Height), keys: {sorted(event)}")
    if not (np.isfinite(x) and np.isfinite(y)) or not (0.0 <= x <= 1.0 and 0.0 <= y <= 1.0):
        raise ClickRefused(f"the click at ({x:.3f}, {y:.3f}) of the image's width/height is outside the image")
    return float(np.clip(x * W - 0.5, 0.0, W - 1.0)), float(np.clip(y * H - 0.5, 0.0, H - 1.0))


def scaled_size(frame_size: tuple[int, int], scale: float) -> tuple[int, int]:
    """(w, h) px of a frame of frame_size = (W, H) px shown downscaled by `scale`."""
    return max(1, round(frame_size[0] * scale)), max(1, round(frame_size[1] * scale))


def encode_view(rgb: np.ndarray, scale: float = 0.5, marker: tuple[float, float] | None = None,
                quality: int = 85) -> tuple[bytes, tuple[int, int]]:
    """JPEG bytes of an RGB frame (H, W, 3) uint8 downscaled by `scale`, with a ring at camera pixel `marker`;
    returns (bytes, (w, h)) of the encoded image."""
    rgb = np.asarray(rgb)
    if rgb.ndim != 3 or rgb.shape[2] != 3 or rgb.dtype != np.uint8:
        raise ValueError(f"the frame must be RGB (H, W, 3) uint8, got {rgb.dtype} with shape {rgb.shape}")
    if not 0.05 <= scale <= 1.0:
        raise ValueError(f"scale must lie in [0.05, 1], got {scale}")
    H, W = rgb.shape[:2]
    w, h = scaled_size((W, H), scale)
    bgr = cv2.resize(np.ascontiguousarray(rgb[..., ::-1]), (w, h), interpolation=cv2.INTER_AREA)
    if marker is not None:
        centre = (round((marker[0] + 0.5) * w / W - 0.5), round((marker[1] + 0.5) * h / H - 0.5))
        cv2.circle(bgr, centre, 8, MARKER_RGB[::-1], 2, cv2.LINE_AA)
    ok, buf = cv2.imencode(".jpg", bgr, [cv2.IMWRITE_JPEG_QUALITY, int(quality)])
    if not ok:
        raise RuntimeError("OpenCV could not JPEG-encode the frame")
    return buf.tobytes(), (w, h)


@dataclass(frozen=True)
class ClickResult:
    """What one click did. action: "grab" or "drop"; uv: camera pixel; ok: the block is held (grab) or was put down
    (drop); world: the clicked surface point (3,) mm, None when the click was refused before that; commands: the
    arm commands sent, in order (("move", q (5,) rad, moving_time s), ("open",), ("close", held)); message: one line
    for the user."""

    action: str
    uv: tuple[float, float]
    ok: bool
    world: np.ndarray | None
    message: str
    commands: tuple = field(default=(), repr=False)

    @property
    def moved(self) -> bool:
        """True when any command reached the arm."""
        return bool(self.commands)


def _num(x: float) -> str:
    return str(int(round(float(x))))           # whole numbers, no "-0"


def _fmt(p) -> str:
    return "(" + ", ".join(_num(x) for x in p) + ")"


def _summary(log: list) -> str:
    moves = [c for c in log if c[0] == "move"]
    seconds = sum(c[2] or 0.0 for c in moves)
    grip = ", ".join("open" if c[0] == "open" else f"close ({'holding' if c[1] else 'empty'})"
                     for c in log if c[0] != "move")
    return f"{len(moves)} arm moves ({seconds:.1f} s of motion)" + (f", gripper {grip}" if grip else "")


class ClickToGrab:
    """Grab on the first click, drop on the next, from pixels of the current camera frame.

    Args:
        session: the task session (tasks.start_session(station), sim or real) whose arm the clicks move.
        scale: the shown image is the camera frame downscaled by this factor (clicks are mapped back).
        yaw: the yaw (rad) the dropped block is put down with.
        display_width: CSS width of the shown image in px (default: its encoded width); the browser may draw it at
            any size, the click mapping does not depend on it.
        machine: a tasks.TaskMachine over the same session: clicks then run as its click-grab / click-drop commands
            (refused while it is busy or emergency-stopped); default: tasks.click_grab / click_drop directly.
        sequence: a click sequence of one's own (on_click(point, seen), after(action, ok): tasks.click_with), which
            then decides what each click means (not with a machine); `yaw` is then the sequence's to give.
    """

    def __init__(self, session: Session, scale: float = 0.5, yaw: float = 0.0, display_width: int | None = None,
                 machine=None, sequence=None):
        session = as_session(session, "ClickToGrab")
        if not 0.05 <= scale <= 1.0:
            raise ValueError(f"scale must lie in [0.05, 1], got {scale}")
        if machine is not None and machine.session is not session:
            raise ValueError("the TaskMachine given drives another session")
        if sequence is not None and (machine is not None or not callable(getattr(sequence, "on_click", None))
                                     or not callable(getattr(sequence, "after", None))):
            raise ValueError("a click sequence has on_click(point, seen) and after(action, ok), and runs without a "
                             "machine (tasks.click_with)")
        self.sequence = sequence
        self.session, self.station = session, session.station
        self.scale, self.yaw = float(scale), float(yaw)
        self.display_width = display_width
        self.machine = machine
        self.history: list[ClickResult] = []
        self._image = self._out = self._title = None
        self._marker: tuple[float, float] | None = None

    @property
    def holding(self):
        """The detected Block in the gripper, or None."""
        return self.session.held

    @property
    def marker(self) -> tuple[float, float] | None:
        """The last clicked camera pixel (u, v) (marked on the shown image), or None."""
        return self._marker

    @property
    def next_action(self) -> str:
        """What the next click does: "grab" or "drop"."""
        return "grab" if self.holding is None else "drop"

    def frame_size(self) -> tuple[int, int]:
        """(W, H) px of the camera frame the clicks refer to."""
        H, W = current_view(self.session).frame.rgb.shape[:2]
        return W, H

    def image_size(self) -> tuple[int, int]:
        """(w, h) px of the shown (encoded) image; click events refer to it."""
        return scaled_size(self.frame_size(), self.scale)

    def view(self) -> tuple[bytes, tuple[int, int]]:
        """The shown image: (JPEG bytes, (w, h) px) of the current frame with the last click marked."""
        return encode_view(current_view(self.session).frame.rgb, self.scale, self._marker)

    def click(self, uv, check_view: bool = True) -> ClickResult:
        """Act on a click at camera pixel uv = (u, v): grab when the gripper is empty, else drop. Never raises for
        a refused click or a refused/stopped motion: the result says why (and records what was sent, if anything).

        With check_view (default), a click on a view that is no longer current (the arm moved since the look, see
        view_is_current) is refused after a new look (the arm moves out of view, nothing else): the user clicked a
        picture of the past. A caller that has just shown a frame taken now passes check_view=False (the station
        panel does, after looking again itself)."""
        uv = tuple(float(c) for c in np.asarray(uv, dtype=float).reshape(-1))
        action = self.next_action
        session = self.session
        world, ok = None, False
        valid = len(uv) == 2 and bool(np.all(np.isfinite(uv)))
        where = f"{action} at pixel {_fmt(uv)}" if valid else f"{action} at {uv}"
        with session.arm.recording() as log:
            try:
                if not valid:
                    raise ClickRefused(f"a click is a pixel (u, v) of 2 finite numbers, got {uv}")
                if check_view and not view_is_current(session):
                    self._look()
                    raise ClickRefused("the picture was out of date (the arm had moved since it was taken): the "
                                       "camera looked again, click on the new picture")
                world = click_world(session, uv, current_view(session).frame)
                where += f" -> world {_fmt(world)} mm"
                del log[:]                      # what the click did, not the look that may have come before
                held = session.held
                if self.sequence is not None:   # the sequence decides what the click means
                    action, ok = self._by_sequence(uv)
                    where = f"{action}{where[where.index(' at pixel'):]}"
                if action == "grab":
                    ok = ok if self.sequence is not None else self._grab(uv)
                    block = session.held
                    did = (f"holding the {block.color} {block.size} block (top face {_fmt(block.position)} mm, "
                           f"yaw {_num(np.degrees(block.yaw))} deg)" if ok else "the gripper closed empty (missed)")
                else:
                    ok = ok if self.sequence is not None else self._drop(uv)
                    did = f"put the {held.color} block down there"
                message = f"{where}: {did}; {_summary(log)}"
            except (ClickRefused, MachineBusy) as e:
                if world is None:
                    del log[:]                  # refused before the click's action: a look is not what it did
                message = f"{where}: refused, nothing moved: {e}"
            except (MotionRefused, EmergencyStopped) as e:
                if world is None:
                    del log[:]
                message = (f"{where}: stopped by the arm after {_summary(log)}: "
                           f"{type(e).__name__}: {str(e).splitlines()[0]}")
        result = ClickResult(action, uv[:2], bool(ok), world, message, tuple(log))
        self.history.append(result)
        if valid:
            self._marker = uv
        self._refresh()
        return result

    def _by_sequence(self, uv) -> tuple[str, bool]:
        """One click through tasks.click_with and the panel's sequence; what it cannot act on (an action the kit
        refuses, nothing held to drop, out of reach: a ValueError, before anything moves) is a refused click."""
        try:
            return click_with(self.session, uv, self.sequence)
        except ClickRefused:
            raise
        except ValueError as e:
            raise ClickRefused(f"your click sequence's answer cannot be acted on: {e}") from None

    def _grab(self, uv) -> bool:
        if self.machine is not None:
            return self.machine.click_grab(uv)
        return click_grab(self.session, uv)

    def _drop(self, uv) -> bool:
        if self.machine is not None:
            return self.machine.click_drop(uv)
        return click_drop(self.session, uv, self.yaw)

    def _look(self) -> None:
        if self.machine is not None:
            self.machine.detect()
        else:
            look(self.session)

    def handle_event(self, event: Mapping) -> ClickResult | None:
        """The ipyevents callback: a "click" event dict -> click(pixel); other event types are ignored (None).
        The result's message is appended to the panel's output area when the panel exists."""
        if event.get("type") != "click":
            return None
        try:
            uv = event_pixel(event, self.frame_size(), self.image_size())
        except ClickRefused as e:
            result = ClickResult(self.next_action, (np.nan, np.nan), False, None, f"refused, nothing moved: {e}")
            self.history.append(result)
        else:
            result = self.click(uv)
        if self._out is not None:       # straight into the panel, never the cell's own output
            self._out.append_stdout(result.message + "\n")
        return result

    def _refresh(self) -> None:
        if self._image is not None:
            self._image.value = self.view()[0]
        if self._title is not None:
            self._title.value = self._title_html()

    def _title_html(self) -> str:
        W, H = self.frame_size()
        iw, ih = self.image_size()
        return (f"<b>click-to-grab</b> ({W}x{H} frame shown at {iw}x{ih} px): <b>{holding_text(self.session)}</b>")

    def widget(self, fresh: bool = True):
        """The live panel: a title saying what is held and what the next click does, the clickable image and an
        output area for the messages (an ipywidgets.VBox whose text form is one deterministic line under 110
        characters, which nbval compares). With fresh (default), the camera looks again first when the last look
        is out of date (view_is_current), so the panel never opens on a picture of the past. Needs ipywidgets and
        ipyevents."""
        try:
            import ipywidgets as w
            from ipyevents import Event
        except ImportError as e:
            raise ImportError(f"the click panel needs ipywidgets and ipyevents (pip install -r requirements.txt): "
                              f"{e}") from e
        if fresh and not view_is_current(self.session):
            self._look()
        data, (iw, ih) = self.view()
        width = self.display_width or iw
        self._image = w.Image(value=data, format="jpeg", layout=w.Layout(width=f"{width}px", height="auto"))
        self._out = w.Output()
        self._events = Event(source=self._image, watched_events=["click"], prevent_default_action=True)
        self._events.on_dom_event(self.handle_event)
        W, H = self.frame_size()
        label = f"click-to-grab panel ({W}x{H} frame shown at {iw}x{ih} px): run the cell, then click a block"
        self._title = w.HTML(self._title_html())

        class ClickPanel(w.VBox):
            def __repr__(self) -> str:      # the text form nbval compares: no image bytes, no widget ids
                return label

        return ClickPanel([self._title, self._image, self._out])

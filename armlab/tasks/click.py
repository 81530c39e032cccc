"""Click-to-grab and click-to-drop: a pixel (u, v) of the current camera frame -> world point -> plan -> execute.

Every function takes the task session (tasks.start_session(station)) first. The current frame is the last look at
the board (tasks.look: arm out of view; session.last.frame is what a GUI shows; both functions look again after
acting). The pixel goes to the world through the calibrated camera
and the corrected depth (perception.pointed_point: the median depth of the surface around the pixel, the rule
the control station's readout shows too; Camera.pixel_to_world).
click_grab picks the detected block the click means and click_drop puts the held block's bottom face on the surface
under the click (the board, or the top of a block or stack), each by the kit's click rule (click_rule()): in the
instructor's tree the kit's own (armlab.tasks.click_rule: the nearest top-face centre within one block edge, and a
click where the held block stood puts it back on what it stood on), left out of the student release, where it
answers exercise grab.sequence; the release runs a lesser stand-in instead (centre_click_block: only a click within
CENTRE_CLICK_PX of a block's detected centre pixel grabs; standin_drop_point: a click on the held block's old place
is refused). A student's own sequence runs through click_with (notebook 05).
Everything is checked and planned before anything moves: a click off the board, on the robot, on bare board
(grab), or where the arm cannot reach raises ClickRefused (a ValueError) and the arm stays where it is.
Units: px, mm, rad; world (board) frame.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from armlab import motion_safety
from armlab.arguments import finite_array, finite_float, plain
from armlab.blocks import block_edge
from armlab.kinematics import Unreachable
from armlab.slots import kit_or_standin

from . import perception
from .handling import look, pick, place
from .refusal import ClickRefused
from .session import Session, as_session

__all__ = ["ClickRefused", "click_grab", "click_drop", "click_with", "click_world", "current_view", "click_rule",
           "centre_click_block", "standin_drop_point", "CENTRE_CLICK_PX"]

CENTRE_CLICK_PX = 6.0      # the release's stand-in grabs a block only within this distance of its detected centre pixel


GrabRule = Callable[[list, np.ndarray, np.ndarray], Any]
DropRule = Callable[[Any, np.ndarray], np.ndarray]


def centre_click_block(blocks: list, point: np.ndarray, uv: np.ndarray):
    """The release's stand-in for the kit's grab rule: of the detected `blocks`, the one whose centre pixel
    (Block.pixel) is nearest the clicked pixel uv (2,) px, when it lies within CENTRE_CLICK_PX; ClickRefused otherwise
    (`point`, the clicked surface point (3,) world mm, only names the click). Lesser than the lab's rule on purpose:
    a click anywhere else on a top face is refused."""
    d = np.array([np.hypot(*(np.asarray(b.pixel, float) - uv)) for b in blocks])
    if d.min() > CENTRE_CLICK_PX:
        raise ClickRefused(f"no block centre at the click ({point[0]:.0f}, {point[1]:.0f}) mm: the nearest is "
                           f"{d.min():.0f} px away, and the student release's click rule grabs only within "
                           f"{CENTRE_CLICK_PX:.0f} px of a block's detected centre (your own rule: exercise "
                           f"grab.sequence, notebook 05, run by tasks.click_with)")
    return blocks[int(np.argmin(d))]


def standin_drop_point(held, point: np.ndarray) -> np.ndarray:
    """The release's stand-in for the kit's drop rule: where the held block's bottom face goes for a click at the
    surface point `point` (3,) world mm: the point itself; a click within one edge of where the held block was seen
    (the frame still shows it there) is refused (ClickRefused), since this rule does not know what it stood on."""
    if np.hypot(*(point[:2] - np.asarray(held.position[:2], float))) < held.edge_mm:
        raise ClickRefused(f"the picture still shows the held {held.color} block at the click: the student "
                           f"release's click rule cannot tell what it stood on; drop it somewhere else")
    return point


def click_rule() -> tuple[GrabRule, DropRule]:
    """(grab rule, drop rule) of click_grab / click_drop: the kit's own (armlab.tasks.click_rule.grab_target /
    drop_point) where it is installed (the instructor's tree), the release's stand-ins centre_click_block /
    standin_drop_point otherwise (module notes)."""
    kit = f"{__package__}.click_rule"
    return (kit_or_standin(kit, "grab_target", centre_click_block),
            kit_or_standin(kit, "drop_point", standin_drop_point))


def click_world(session: Session, uv, frame=None) -> np.ndarray:
    """World point (3,) mm of the surface at pixel uv of `frame` (default: a new capture), depth corrected; raises
    ClickRefused where the placement rule refuses the point itself (motion_safety.placement_problem: off the board,
    on the robot's base plate)."""
    session = as_session(session, "tasks.click_world")
    uv = _pixel(uv)
    frame = frame or session.station.camera.capture()
    depth = session.calibration.depth_correction.apply(frame.depth)
    try:
        p = perception.pointed_point(session.calibration, depth, uv)
    except ValueError as e:
        raise ClickRefused(f"click at {plain(tuple(np.round(uv, 1)))}: {e}") from None
    problem = motion_safety.placement_problem(p, reach=False)      # reach: the pick's or the drop's to judge
    if problem:
        raise ClickRefused(f"click at {problem}")
    return p


def _pixel(uv) -> np.ndarray:
    """A clicked pixel (2,) (u, v) px, or the kit's ValueError / TypeError naming uv."""
    return finite_array(uv, "uv", (2,), "the clicked pixel (u, v) of the current frame")


def current_view(session: Session) -> perception.Observation:
    """The frame the user sees: the session's last look (taken now, arm out of view, when there is none yet)."""
    session = as_session(session, "tasks.current_view")
    return session.last if session.last is not None else look(session)


def click_grab(session: Session, uv) -> bool:
    """Pick the block the click at pixel uv = (u, v) of the current frame means (the click rule, click_rule(): module
    notes); True when it is held (see tasks.pick). The view is refreshed (tasks.look) after the pick."""
    session = as_session(session, "tasks.click_grab")
    uv = _pixel(uv)
    if session.held is not None:
        raise ClickRefused(f"the gripper already holds the {session.held.color} block: drop it first")
    obs = current_view(session)
    p = click_world(session, uv, obs.frame)
    if not obs.blocks:
        raise ClickRefused(f"no block on the board to grab (click at ({p[0]:.0f}, {p[1]:.0f}) mm)")
    best = click_rule()[0](list(obs.blocks), p, uv)
    try:
        held = pick(session, best)
    except Unreachable as e:
        raise ClickRefused(f"the {best.color} block at ({best.position[0]:.0f}, {best.position[1]:.0f}) mm cannot "
                           f"be picked: {e}") from None
    look(session)
    return held


def click_drop(session: Session, uv, yaw: float = 0.0) -> bool:
    """Put the held block on the surface under pixel uv = (u, v) of the current frame (see tasks.place), where the
    click rule (click_rule(), module notes) says its bottom face goes. The view is refreshed after the drop."""
    session = as_session(session, "tasks.click_drop")
    uv, yaw = _pixel(uv), finite_float(yaw, "yaw", what="rad")
    if session.held is None:
        raise ClickRefused("the gripper holds no block: grab one first")
    p = click_world(session, uv, current_view(session).frame)
    held = session.held
    p = np.asarray(click_rule()[1](held, p), dtype=float)
    problem = motion_safety.placement_problem(p, block_edge(held.size), yaw)      # the rule tasks.place applies
    if problem:
        raise ClickRefused(f"cannot drop at ({p[0]:.0f}, {p[1]:.0f}, {p[2]:.0f}) mm: {problem}")
    try:
        done = place(session, p, yaw)
    except Unreachable as e:
        raise ClickRefused(f"cannot drop at ({p[0]:.0f}, {p[1]:.0f}, {p[2]:.0f}) mm: {e}") from None
    look(session)
    return done


def click_with(session: Session, uv, sequence) -> tuple[str, bool]:
    """One click run by a click-to-grab sequence of one's own (exercise grab.sequence, notebook 05): the world point
    under pixel uv of the current frame (click_world) and the view's detections go to sequence.on_click(point, seen),
    which returns ("grab", block) -- a block of `seen` -- or ("drop", position (3,) mm, yaw rad), or raises
    ClickRefused; the kit then picks the block (tasks.pick) or places the held one with its bottom-face centre at
    the position (tasks.place), looks again, and tells the sequence sequence.after(action, ok). Returns (what was
    done, whether it worked: the block held / the place ran through). Any other answer is a ValueError, and nothing
    moves."""
    session = as_session(session, "tasks.click_with")
    view = current_view(session)
    point = click_world(session, _pixel(uv), view.frame)
    action = sequence.on_click(point, list(view.blocks))
    kind = action[0] if isinstance(action, (tuple, list)) and action else None
    if kind == "grab" and len(action) == 2 and any(action[1] is b for b in view.blocks):
        ok = bool(pick(session, action[1]))
    elif kind == "drop" and len(action) == 3:
        position = finite_array(action[1], "the drop's position", (3,), "world mm")
        ok = bool(place(session, position, finite_float(action[2], "the drop's yaw", what="rad")))
    else:
        raise ValueError(f"a click's action is ('grab', a block of those seen) or ('drop', position, yaw), got "
                         f"{plain(action)}")
    look(session)
    sequence.after(action, ok)
    return kind, ok


"""The task layer's session: a station together with what the kit has learned about it (camera calibration, sag
model) and what it knows of the board (the blocks seen, the block held). One call starts it:

    session = tasks.start_session(station)       # calibrates the camera and fits the sag model HERE
    tasks.pick(session, block); tasks.place(session, spot)

Every motion goes through the session's one executor, session.run(plan, what) (tasks.executor): the whole plan is
checked before its first command, with what is held and what is known on the board. Every behaviour of
armlab.tasks (look, pick, place, put_back, the clicks, move_path's grab_with / drop_with, the TaskMachine, the event
runner, the reach experiment) and the GUIs of armlab.ui take the session as their first argument. Nothing is kept
on the station: two sessions over one station are two independent sets of knowledge (do not drive one arm from both
at once). A bare station passed where a session is wanted raises a TypeError saying to
start one. Units: mm, rad; world (board) frame.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from armlab import planning
from armlab.arguments import instance_of
from armlab.blocks import block_edge
from armlab.calibration import Calibration
from armlab.planning import Obstacle
from armlab.station.contract import Station

from . import executor, perception
from .guard import GuardedArm
from .sag import SagModel, calibration_poses, fit_sag, hover_pose

__all__ = ["Session", "start_session", "calibrate_sag", "as_session", "same_spot"]

START = "session = tasks.start_session(station)"


@dataclass(eq=False)
class Session:
    """A station in use by the task layer (see the module notes); made by start_session. Built directly,
    Session(station, GuardedArm(station.arm)) is one with no calibration and no sag model, made without moving
    anything: enough for teaching by hand and for stand-ins, not for looking at the board.

    Attributes:
        station: the station (make_station(...)); its raw arm is station.arm.
        arm: the GuardedArm every task moves through (sag compensation, stop requests, speed checks).
        calibration: the camera calibration (armlab.calibration.Calibration), None until calibrated.
        held: the detection Block in the gripper (picked by the task layer), or None.
        known: what stands on the board (the blocks of the last look, updated by picks and places): the obstacles
            plans avoid.
        last: the last look (perception.Observation), None before the first.
        held_in_tool: T_tool_block (4, 4) mm of the held block as planned at its grasp, or None.
        picked_down: the held block's pick descent (its straight line down), for put_back, or None.
    """

    station: Station
    arm: GuardedArm
    calibration: Calibration | None = None
    held: object | None = None
    known: list = field(default_factory=list)
    last: perception.Observation | None = None
    held_in_tool: np.ndarray | None = None
    picked_down: object | None = None

    def run(self, plan: planning.Plan, what: str, **options) -> planning.ExecutionResult:
        """Check `plan` whole, then run it on the guarded arm and record what is held: the one executor
        (tasks.executor.run; options: grasp, known, column, release_top, arm). MotionRefused with nothing sent when
        the placement rule or the whole-plan check refuses; `what` names the motion in the message."""
        return executor.run(self, plan, what, **options)

    @property
    def held_edge(self) -> float:
        """Edge (mm) of the held block; ValueError when nothing is held."""
        if self.held is None:
            raise ValueError("the gripper holds no block: pick one first")
        return block_edge(self.held.size)

    def picked(self, block, held: bool, held_in_tool: np.ndarray | None = None, descent=None) -> None:
        """Record a pick of `block` (a detection Block) that ran: it leaves the known blocks, and when `held` it is
        the held block, with its pose in the tool frame T_tool_block (4, 4) mm and the pick's straight descent."""
        self.known = [k for k in self.known if not same_spot(k, block)]
        if held:
            self.held, self.held_in_tool, self.picked_down = block, held_in_tool, descent

    def released(self, top) -> None:
        """Record that the held block was let go with its top-face centre at `top` (3,) world mm: nothing is held,
        and the block joins the known blocks (an obstacle of its footprint's radius)."""
        edge = self.held_edge
        self.held, self.held_in_tool, self.picked_down = None, None, None
        x, y, z = (float(c) for c in np.asarray(top, float))
        self.known = [*self.known, Obstacle(x, y, z, edge / np.sqrt(2))]


def same_spot(a, b) -> bool:
    """True when two known things (detection Blocks by their top-face centre, or planning Obstacles by their top)
    stand within 1 mm of each other on every axis."""
    def top(k):
        return (k.x, k.y, k.top) if isinstance(k, Obstacle) else k.position
    return bool(np.abs(np.asarray(top(a), float) - np.asarray(top(b), float)).max() < 1.0)


def calibrate_sag(arm, measure: Callable[[], np.ndarray], poses=None) -> SagModel:
    """Fit a SagModel: move the raw arm (no compensation) to each pose (default sag.calibration_poses), passing
    above it first, and call measure() -> tool point (3,) world mm there. Returns the fitted model.

    Every move goes through the executor (tasks.executor.run over the arm alone: the whole move checked before its
    first command, nothing known on the board, what the arm says it holds). arm: a backend's Arm, or a GuardedArm
    whose backend arm is moved without its sag model (the fit measures the uncompensated arm). MotionRefused, with
    the arm where it was, when a pose's move is refused."""
    raw = arm.arm if isinstance(arm, GuardedArm) else arm
    mover = executor.ArmAlone(GuardedArm(raw))
    poses = calibration_poses(raw.robot) if poses is None else np.asarray(poses, dtype=float)
    q_cmd, measured = [], []
    for k, q in enumerate(poses):
        what = f"fitting the sag model: pose {k + 1} of {len(poses)}"
        above = hover_pose(q, raw.robot)
        path = [q] if above is None else [above, q]
        here = np.asarray(raw.joint_positions(), dtype=float)
        executor.run(mover, planning.joint_moves(here, *path, label="to the pose, move", robot=raw.robot), what)
        q_cmd.append(np.asarray(raw.joint_positions(), dtype=float))
        measured.append(np.asarray(measure(), dtype=float))
        if above is not None:
            executor.run(mover, planning.joint_moves(q_cmd[-1], above, label="back up, move", robot=raw.robot),
                         f"{what}: back up")
    return fit_sag(np.array(q_cmd), np.array(measured), raw.robot)


def start_session(station: Station, intrinsics="checkerboard", sag: SagModel | None = None,
                  calibration: Calibration | None = None) -> Session:
    """Start the task layer on `station`: fit the sag model and calibrate the camera, now. Returns the Session.

    - sag: the given model, else fitted when the station offers a reference to fit it on
      (Capabilities.sag_reference: in simulation the same arm over an empty board, measured with the ground truth;
      24 poses, it moves that twin arm, not this one), else zero (the real arm: fit one with calibrate_sag and a
      measuring function, or load a saved model, and pass it).
    - calibration: the given one, else perception.calibrate_camera(station, intrinsics): intrinsics
      "checkerboard" (the camera's own checkerboard set), "factory" (the device's K, dist) or a (K, dist) pair;
      extrinsics from the board's AprilTags and the depth-plane correction from one frame. This MOVES THE ARM out
      of the camera's view (through the session's guarded arm) before the frame is taken.
    Raises TypeError when `station` is not a Station, ValueError when the tags are not seen or the board has too
    little depth.
    """
    instance_of(station, "station", Station, "what make_station('sim') or make_station('real') returns")
    arm = GuardedArm(station.arm)
    if sag is not None:
        arm.sag = instance_of(sag, "sag", SagModel, "a tasks.SagModel, e.g. from tasks.calibrate_sag")
    elif station.capabilities.sag_reference is not None:
        reference = station.capabilities.sag_reference()
        arm.sag = calibrate_sag(reference.arm, reference.measure)
    session = Session(station, arm)
    if calibration is not None:
        session.calibration = instance_of(calibration, "calibration", Calibration, "an armlab.calibration.Calibration")
    else:
        session.calibration = perception.calibrate_camera(station, intrinsics, arm=session)
    return session


def as_session(value: object, what: str) -> Session:
    """`value` itself when it is a Session; TypeError otherwise, naming `what` (e.g. "tasks.pick") and, for a bare
    station, the call that starts a session."""
    if isinstance(value, Session):
        return value
    if isinstance(value, Station):
        raise TypeError(f"{what} takes a task session, not a station: start one first with `{START}` (it "
                        f"calibrates the camera and fits the sag model), then pass the session")
    raise TypeError(f"{what} takes a task session (from tasks.start_session(station)), got {type(value).__name__}")

"""Grasp pose choice for a block: wrist roll from the block's yaw, top-down pitch with a fallback at long reach.

Frames: world (board) mm and rad. The tool frame is ee_gripper_link (x = approach, y = the fingers' closing
direction). For a tool point in the vertical arm plane at heading h = atan2(y, x), IK gives the orientation
kinematics.tool_orientation(h, pitch, roll) = Rz(h) Ry(pitch) Rx(roll), whose y column is

    y_tool = (cos h sin(pitch) sin(roll) - sin h cos(roll),  sin h sin(pitch) sin(roll) + cos h cos(roll),
              cos(pitch) sin(roll)).

Top-down (pitch = pi/2): y_tool = (sin(roll - h), cos(roll - h), 0), a horizontal direction at angle
pi/2 + h - roll from world +x. A cube of yaw `yaw` has face normals at yaw + k pi/2, so the fingers close across two
opposite faces when pi/2 + h - roll = yaw (mod pi/2), i.e. roll = h - yaw (mod pi/2); the smallest wrist turn takes
the representative in (-pi/4, pi/4] (face_roll).

Tilted (pitch < pi/2, at long reach): in the arm plane's frame (along the heading, across it, up) the closing
direction is Ry(pitch) Rx(roll) e_y = (sin(pitch) sin(roll), cos(roll), cos(pitch) sin(roll)), so a roll turns its
horizontal part by atan2(sin(pitch) sin(roll), cos(roll)) from across the arm plane but also tilts it by
asin(cos(pitch) sin(roll)) from horizontal (flat pads then meet the vertical faces a little off flat). tilted_roll
takes the roll that turns the horizontal part onto a face normal, tan(roll) = tan(face_roll) / sin(pitch), as long as
the tilt stays within MAX_CLOSING_TILT_RAD (half the simulated gripper's 10 deg tolerance; rubber pads take it); beyond
that the roll stops at that tilt and the rest is left as `misalignment` (a closing parallel gripper turns the block
square to its fingers). Just short of top-down (89 deg at 400 mm out) the roll is the top-down one; the flatter the
pitch, the less of it fits (cos(pitch) sin(roll) grows): at 420 mm (pitch 83 deg) a block 45 deg off the arm plane
is still met square, at pitch 45 deg only 7 deg of turn fits. The grasp reports the misalignment so a caller can
prefer another block or nudge it.

Pad clearance (choose_grasp's obstacles): a top-down grasp can close across either pair of faces (roll and roll +-
pi/2). The open pads stand out beside the block along the closing direction (their outer faces finger_max_mm from the
centre line), so with a neighbour close on that side they brush it and turn it. The grasp takes the smaller turn
unless its pads come within PAD_CLEARANCE_MM of a neighbour (an obstacle cylinder whose top is above the pads'
lowest point) and the other pair leaves more room.

Levelling a held block (level_pitch_roll, for a release): a tool at heading h, pitch p and roll r turns a direction
u of the tool frame into Rz(h) Ry(p) Rx(r) u, which is world up, whatever h, when Ry(p) Rx(r) u = e_z, i.e. u is the
last row of Ry(p) Rx(r): u = (-sin p, cos p sin r, cos p cos r). So a held cube with the face normal u (tool frame)
is let go with that face up, and its faces level, at p = atan2(-u_x, hypot(u_y, u_z)) and r = atan2(u_y, u_z): for a
cube gripped level at pitch p0 and roll r0 (u = Rx(-r0) Ry(-p0) e_z), the pick's own pitch and roll. Top-down
(u = -x of the tool) any roll levels it; otherwise the roll is fixed, and so is the cube's yaw relative to the arm
plane: a level release keeps the yaw the cube had to the arm plane at its grasp, not a requested one.

Joint-limit margin: the steepest pitch sits where a joint (usually wrist_angle) reaches its position limit, and the
task layer's sag compensation (armlab.tasks.sag, a few mrad) would push such a command past the limit. So pitches
and IK solutions are chosen first with every limit pulled in by LIMIT_MARGIN_RAD (inner_limits), and only when
nothing works with the margin with the limits themselves.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from armlab import kinematics
from armlab.gripper_geometry import GRIPPER, GripperGeometry
from armlab.kinematics import Unreachable
from armlab.robot import RobotModel, rx200
from armlab.transforms import wrap_quarter

from . import descent

__all__ = ["GraspPose", "face_roll", "tilted_roll", "face_misalignment", "choose_grasp", "TOP_DOWN",
           "LIMIT_MARGIN_RAD", "MAX_CLOSING_TILT_RAD", "PAD_CLEARANCE_MM", "pad_clearance", "inner_limits",
           "steepest_pitch_inside", "level_pitch_roll"]

TOP_DOWN = np.pi / 2
LIMIT_MARGIN_RAD = 0.01         # planned poses keep this far inside the position limits where they can (module notes)
PAD_CLEARANCE_MM = 5.0          # an open pad this close to a neighbour takes the other pair of faces if it is freer
MAX_CLOSING_TILT_RAD = np.radians(5.0)   # a tilted grasp's closing direction stays this close to horizontal
_PITCH_STEP = np.radians(1.0)   # fallback pitches are tried from the steepest downwards in this step


@dataclass(frozen=True)
class GraspPose:
    """Where and how the tool grasps: tool point position (3,) world mm, heading, pitch and roll (rad).

    top_down: pitch is pi/2. misalignment: angle (rad) between the fingers' closing direction and the nearest block
    face normal (0 when the fingers are square across two faces).
    """

    position: np.ndarray
    heading: float
    pitch: float
    roll: float
    top_down: bool
    misalignment: float


_TIE_RAD = 1e-9   # face_roll: within this of -pi/4 counts as the tie at +pi/4


def face_roll(heading: float, yaw: float) -> float:
    """Wrist roll (rad, in (-pi/4, pi/4]) that closes top-down fingers across two opposite faces of a block of
    yaw `yaw` (rad) seen from an arm plane at `heading` (rad): roll = heading - yaw (mod pi/2), the smaller turn.
    A block turned 45 deg to the arm plane (a tie: both rolls meet two faces) gets +pi/4 on every CPU: heading - yaw
    within _TIE_RAD of -pi/4 (mod pi/2) counts as the tie, since a heading computed with another CPU's arctan2 kernel
    (the sky tower's spot on the diagonal, x = y) comes out exactly pi/4 on one and one ulp below on another, and
    wrapped to opposite sides. (+pi/4, not -pi/4: the to-the-sky tower, whose tilted levels come in on that tie, stood
    12 high on seeds 0-7 with +pi/4 and fell at 9 on seed 3 with -pi/4.)
    """
    roll = float(wrap_quarter(heading - yaw))
    return roll + np.pi / 2 if roll < -np.pi / 4 + _TIE_RAD else roll


def tilted_roll(heading: float, pitch: float, yaw: float, max_tilt: float = MAX_CLOSING_TILT_RAD) -> float:
    """Wrist roll (rad) that turns the horizontal part of the closing direction of a tool at `pitch` rad (pi/2:
    top-down) onto a face normal of a block of yaw `yaw` rad seen from an arm plane at `heading` rad, with the closing
    direction tilted at most max_tilt rad from horizontal (module notes): face_roll when top-down."""
    delta = face_roll(heading, yaw)
    s = np.sin(pitch)
    roll = float(np.arctan2(np.tan(delta), s)) if s > 1e-9 else 0.0
    c = abs(np.cos(pitch))
    if c * abs(np.sin(roll)) > np.sin(max_tilt):
        roll = float(np.sign(roll) * np.arcsin(min(1.0, np.sin(max_tilt) / c)))
    return roll


def pad_clearance(position, heading: float, roll: float, obstacles, gripper: GripperGeometry = GRIPPER) -> float:
    """Least horizontal distance (mm) from the fully open pads of a top-down tool at `position` (3,) world mm (the tool
    point), heading and roll (rad) to the obstacles (planning Obstacles: cylinders) whose tops are above the pads'
    lowest point; inf when none. Negative: a pad would overlap that obstacle."""
    p = np.asarray(position, dtype=float)
    phi = np.pi / 2 + heading - roll                       # the closing direction (module notes)
    u, v = np.array([np.cos(phi), np.sin(phi)]), np.array([-np.sin(phi), np.cos(phi)])
    centre = gripper.finger_max_mm - gripper.pad_thickness_mm / 2
    half = np.array([gripper.pad_thickness_mm / 2, gripper.pad_width_mm / 2])
    bottom = p[2] - gripper.pad_height_mm / 2
    best = np.inf
    for o in obstacles:
        if o.top <= bottom:
            continue
        d = np.array([o.x, o.y]) - p[:2]
        for side in (-1.0, 1.0):
            local = np.abs(np.array([d @ u - side * centre, d @ v])) - half      # box distance in the pad's frame
            best = min(best, float(np.linalg.norm(np.maximum(local, 0.0)) + min(local.max(), 0.0)) - o.radius)
    return best


def face_misalignment(heading: float, pitch: float, roll: float, yaw: float) -> float:
    """Angle (rad, 0..pi/4 for a horizontal closing direction) between the tool y axis of
    tool_orientation(heading, pitch, roll) and the nearest face normal of a block of yaw `yaw`."""
    y_tool = kinematics.tool_orientation(heading, pitch, roll)[:, 1]
    normals = np.array([[np.cos(yaw), np.sin(yaw), 0.0], [-np.sin(yaw), np.cos(yaw), 0.0]])
    dots = normals @ y_tool
    k = int(np.argmax(np.abs(dots)))
    # atan2(|n x y|, |n . y|), not arccos(|n . y|): arccos turns a last-bit error of an aligned pair's dot product
    # into 1.5e-8 rad, which then depends on the CPU's rounding
    return float(np.arctan2(np.linalg.norm(np.cross(normals[k], y_tool)), abs(dots[k])))


def level_pitch_roll(R_tool_block) -> tuple[float, float] | None:
    """The tool (pitch, roll) rad that lets a held cube go with its faces level (module notes), from its rotation in
    the tool frame R_tool_block (3, 3) (T_tool_block's): the face that was up when it was gripped (its own z axis, as
    tasks.precheck.held_pose_at_grasp believes a cube gripped level) is put up again, so the pads and finger tips stand
    to its bottom face as they did at the grasp. None when that would need the tool at or above horizontal
    (pitch <= 0)."""
    R = np.asarray(R_tool_block, dtype=float)
    if R.shape != (3, 3) or not np.all(np.isfinite(R)):
        raise ValueError(f"R_tool_block must be a finite (3, 3) rotation, got shape {R.shape}")
    u = R[:, 2]
    pitch = float(np.arctan2(-u[0], np.hypot(u[1], u[2])))
    if pitch <= 0.0:
        return None
    return pitch, float(np.arctan2(u[1], u[2]))


def inner_limits(robot: RobotModel | None = None, margin: float = LIMIT_MARGIN_RAD) -> RobotModel:
    """The robot with every position limit pulled in by `margin` rad (for planning with a margin from the limits)."""
    robot = robot or rx200()
    return dataclasses.replace(robot, lower=robot.lower + margin, upper=robot.upper - margin)


def steepest_pitch_inside(position, roll: float = 0.0, max_pitch: float = TOP_DOWN,
                          robot: RobotModel | None = None) -> tuple[float, RobotModel]:
    """kinematics.steepest_pitch within inner_limits(robot) where the position is reachable so, else within the
    limits themselves; returns (pitch rad, the model whose limits it respects). Raises Unreachable when none."""
    robot = robot or rx200()
    try:
        inner = inner_limits(robot)
        return kinematics.steepest_pitch(position, roll, max_pitch=max_pitch, robot=inner), inner
    except Unreachable:
        return kinematics.steepest_pitch(position, roll, max_pitch=max_pitch, robot=robot), robot


def choose_grasp(position, yaw: float, approach_z: float | None = None,
                 robot: RobotModel | None = None, obstacles=()) -> GraspPose:
    """Grasp (or release) pose for a block whose tool point goes to `position` (3,) world mm, block yaw `yaw` rad.

    Top-down (pitch = pi/2, roll = face_roll) when the kit's descent (planning.descent.approach_reachable) can come
    from approach_z (world mm, default: the position's own height) down to the position; else the steepest pitch
    (from kinematics.steepest_pitch, then in 1 deg steps down) at which it can, with roll = tilted_roll (or 0 where
    only that is reachable; see the module notes).
    obstacles: the neighbours (planning Obstacles) the open pads of a top-down grasp keep clear of by choosing the
    pair of faces (module notes); default none.
    Raises Unreachable saying why when no pitch works, ValueError for bad input.
    """
    robot = robot or rx200()
    p = np.asarray(position, dtype=float)
    if p.shape != (3,) or not np.all(np.isfinite(p)):
        raise ValueError(f"grasp position must be 3 finite numbers (x, y, z in world mm), got {position!r}")
    if not np.isfinite(yaw):
        raise ValueError(f"block yaw must be finite (rad), got {yaw}")
    top_z = p[2] if approach_z is None else float(approach_z)
    if not np.isfinite(top_z):
        raise ValueError(f"approach_z must be finite (mm), got {approach_z}")
    if np.hypot(p[0], p[1]) < 1.0:
        raise Unreachable(f"({p[0]:.1f}, {p[1]:.1f}) mm is on the waist axis: the arm cannot grasp below itself")
    heading = float(np.arctan2(p[1], p[0]))
    roll = face_roll(heading, yaw)
    rolls = [roll]
    obstacles = list(obstacles)
    if obstacles and pad_clearance(p, heading, roll, obstacles) < PAD_CLEARANCE_MM:
        other = roll - np.pi / 2 if roll >= 0 else roll + np.pi / 2       # across the other pair of faces
        if pad_clearance(p, heading, other, obstacles) > pad_clearance(p, heading, roll, obstacles):
            rolls.insert(0, other)
    steepest = None
    for model in (inner_limits(robot), robot):          # with the margin from the limits first (module notes)
        for r in rolls:
            if descent.approach_reachable(p, top_z, TOP_DOWN, r, model):
                return GraspPose(p, heading, TOP_DOWN, r, True, face_misalignment(heading, TOP_DOWN, r, yaw))
        try:
            steepest = kinematics.steepest_pitch(p, robot=model)
        except Unreachable:
            if model is robot:
                raise                                   # the reason, from the limits themselves
            continue
        for pitch in np.arange(min(steepest, TOP_DOWN - _PITCH_STEP), -1e-9, -_PITCH_STEP):
            for r in dict.fromkeys((tilted_roll(heading, pitch, yaw), 0.0)):   # square to the faces, else level
                # a turned wrist must also keep one branch within the limits themselves, where the descent
                # (planning.descent) picks its branch
                reachable = descent.approach_reachable(p, top_z, pitch, r, model)
                if reachable and (r == 0.0 or descent.approach_reachable(p, top_z, pitch, r, robot)):
                    return GraspPose(p, heading, float(pitch), r, False, face_misalignment(heading, pitch, r, yaw))
    raise Unreachable(f"the tool reaches ({p[0]:.1f}, {p[1]:.1f}, {p[2]:.1f}) mm (pitch up to "
                      f"{np.degrees(steepest):.1f} deg) but cannot come straight down to it from z = {top_z:.1f} mm "
                      f"at any pitch")

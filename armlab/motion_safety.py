"""The rules every joint move must pass before anything moves, for the simulated and the real arm alike, and for a
whole plan before its first command.

A move from q_from to q_to (5,) rad is refused (MotionRefused, naming the problem) when:
- the target is malformed (shape, NaN) or outside a joint's position limits (the joint is named);
- its time profile is impossible: moving_time not in (0, MAX_MOVING_TIME_S], accel_time not in [0, moving_time / 2]
  (defaults: armlab.profile.default_moving_time and accel_time = ACCEL_FRACTION x moving_time);
- a joint would be faster than its velocity limit (the driver's rule, armlab.profile.velocity_violations);
- the straight joint-space path (the time-based profile keeps every joint at the same fraction of its change) takes a
  part below its floor over the board (BoardClearance): the joint centres and the tool point (the links between them
  are straight, so their lowest point is one of these), the corners of both finger pads, and the corners of a held
  block. The path is sampled at most PATH_STEP_RAD of the largest joint change apart. A part that starts below its
  floor (after teaching by hand, or at a grasp) may stay where it is or rise, but never sink further.

Each backend names its floors (BoardClearance): pads and held blocks may press BOARD_CONTACT_TOL_MM into the board
on both (rubber pads, wood); the simulator checks the physical joint angles (its sag included), so its links share
that floor (SIM_CLEARANCE), while the real arm checks commanded angles whose unmodelled sag (5-15 mm at long reach)
its links' +10 mm margin covers (REAL_CLEARANCE).

A held block against the other objects (held_intrusion, the one rule for it): along a path sampled at most
HELD_PATH_STEP_RAD apart (held_path_fractions), the held block may go HELD_CONTACT_TOL_MM into another object
(resting on a stack, placing on one, touching a neighbour), and never deeper than it already is at the start of the
path (the block a held block rests on when the lift starts). One routine measures the depths (held_depths: upright
prisms, Prism, by the separating axis theorem); whoever knows where the objects are calls it: the simulator
(armlab.sim.arm, its true objects) and the task layer's pre-check (armlab.tasks.precheck, its detections, with a
smaller allowance that covers detection error), so the two never disagree about the geometry.

Where a held block may be put down (placement_problem, check_placement: the one placement rule, used by
tasks.place, the clicks, the events through tasks.place, and planning.plan_place): its footprint (a square of its
edge, turned by its yaw; a point for a click) must lie on the board, clear of the robot's base plate and
PLACE_BASE_MARGIN_MM around it (data/lab.json's robot_base), and the spot within the arm's reach (the straight arm's
length from the shoulder joint).

Units: rad, s, mm; heights are world z (the board surface is z = 0).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from armlab.arguments import finite_float
from armlab.gripper_geometry import GripperGeometry
from armlab.kinematics import check_joints, frame_points, joint_positions, link_frames
from armlab.lab import LabConfig, lab_config
from armlab.profile import ACCEL_FRACTION, default_moving_time, velocity_violations
from armlab.robot import RobotModel, rx200
from armlab.station.contract import MotionRefused

__all__ = ["BOARD_CONTACT_TOL_MM", "REAL_LINK_MARGIN_MM", "PATH_STEP_RAD", "MAX_MOVING_TIME_S", "LINK_POINTS",
           "PAD_NAMES", "HELD_CONTACT_TOL_MM", "HELD_PATH_STEP_RAD", "BoardClearance", "SIM_CLEARANCE",
           "REAL_CLEARANCE", "HeldBlock", "Segment",
           "Prism", "held_depths", "refusal", "check_target", "check_timing", "path_fractions",
           "held_path_fractions", "held_intrusion", "board_intrusion", "check_move", "check_plan",
           "PLACE_BASE_MARGIN_MM", "arm_reach_mm", "placement_problem", "check_placement"]

BOARD_CONTACT_TOL_MM = 1.0          # a pad or a held block may press this far into the board: not a collision
REAL_LINK_MARGIN_MM = 10.0          # the real arm's links stay this far above the board (unmodelled sag)
PATH_STEP_RAD = np.radians(0.25)    # largest joint change between two checked samples of a path
HELD_CONTACT_TOL_MM = 0.5           # a held block may press this far into another object: not a collision
HELD_PATH_STEP_RAD = 0.01           # the held-object check's path step (coarser than PATH_STEP_RAD for the board: each
                                    # sample costs a penetration test per pair of object pieces)
# In time-based profile mode the servos' Profile_Velocity register holds the moving time in ms, at most 32737
# (ROBOTIS e-manual, X-series control table); the driver passes a larger value on and the servo ignores it.
MAX_MOVING_TIME_S = 32.737
PLACE_BASE_MARGIN_MM = 10.0         # nothing is put down within this of the robot's base plate
LINK_POINTS: tuple[str, ...] = ("shoulder joint", "elbow joint", "wrist joint", "wrist_rotate joint", "tool point")
PAD_NAMES: tuple[str, ...] = ("left finger pad", "right finger pad")
_CUBE_CORNERS = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], dtype=float) / 2


@dataclass(frozen=True)
class BoardClearance:
    """The lowest world z (mm) each kind of part may reach along a move, unless it starts lower.

    Attributes:
        links_mm: the joint centres and the tool point (LINK_POINTS).
        contact_mm: the finger pads' and a held block's corners (default -BOARD_CONTACT_TOL_MM).
    """

    links_mm: float
    contact_mm: float = -BOARD_CONTACT_TOL_MM

    def __post_init__(self):
        for name in ("links_mm", "contact_mm"):
            if not np.isfinite(getattr(self, name)):
                raise ValueError(f"BoardClearance.{name} must be a finite number of mm, got {getattr(self, name)}")


SIM_CLEARANCE = BoardClearance(links_mm=-BOARD_CONTACT_TOL_MM)   # physical angles, sag included
REAL_CLEARANCE = BoardClearance(links_mm=REAL_LINK_MARGIN_MM)    # commanded angles: the margin covers the sag


@dataclass(frozen=True)
class HeldBlock:
    """A cube in the gripper: its edge (mm) and its pose in the tool frame T_tool_block (4, 4) (mm)."""

    edge_mm: float
    T_tool_block: np.ndarray
    name: str = "held block"


@dataclass(frozen=True)
class Segment:
    """One arm command of a plan: move to q (5,) rad in moving_time / accel_time s (None: the defaults) with the
    pads opening_mm apart (None: no pads checked) and the blocks held along it; label names it in a refusal."""

    q: np.ndarray
    moving_time: float | None = None
    accel_time: float | None = None
    opening_mm: float | None = None
    held: tuple[HeldBlock, ...] = ()
    label: str = ""


def refusal(category: str, reason: str) -> MotionRefused:
    """The one form of a refusal: 'motion refused (<category>): <reason> (nothing was sent to the arm)'."""
    return MotionRefused(f"motion refused ({category}): {reason} (nothing was sent to the arm)")


def check_target(q_to, robot: RobotModel | None = None) -> np.ndarray:
    """q_to as a (5,) float array, or MotionRefused naming the problem: shape, NaN, or the joints outside their
    position limits (each named, with its value and limits)."""
    robot = robot or rx200()
    try:
        q = check_joints(q_to, robot, check_limits=False).astype(float)
    except ValueError as e:
        raise refusal("bad target", str(e)) from None
    if q.shape != (5,):
        raise refusal("bad target", f"a move takes one joint vector (5,) rad, got shape {q.shape}")
    limits = robot.limit_violations(q)
    if limits:
        raise refusal("joint limits", "; ".join(limits))
    return q


def check_timing(q_from, q_to, moving_time: float | None = None, accel_time: float | None = None,
                 robot: RobotModel | None = None) -> tuple[float, float]:
    """The (moving_time, accel_time) s to send for a move q_from -> q_to (5,) rad (defaults filled in), or
    MotionRefused for an impossible time profile or a joint faster than its velocity limit (the joint named)."""
    robot = robot or rx200()
    try:
        T = (default_moving_time(q_from, q_to, robot, ACCEL_FRACTION) if moving_time is None
             else finite_float(moving_time, "moving_time", positive=True, what="s"))
        Ta = T * ACCEL_FRACTION if accel_time is None else finite_float(accel_time, "accel_time", what="s")
    except (TypeError, ValueError) as e:
        raise refusal("time profile", str(e)) from None
    if T > MAX_MOVING_TIME_S:
        raise refusal("time profile", f"moving_time {T:g} s is longer than the servos' time profile allows "
                                      f"({MAX_MOVING_TIME_S} s): split the move")
    if not 0 <= Ta <= T / 2 + 1e-12:
        raise refusal("time profile", f"accel_time {Ta} s must lie in [0, moving_time / 2] = [0, {T / 2:g}] s")
    too_fast = velocity_violations(q_from, q_to, T, robot)
    if too_fast:
        raise refusal(f"velocity limits, moving time {T:.2f} s", "; ".join(too_fast))
    return T, Ta


def path_fractions(q_from, q_to, step: float = PATH_STEP_RAD) -> np.ndarray:
    """Fractions s (n,) in [0, 1] at which the straight joint path q_from -> q_to (rad) is checked: at most `step`
    rad of the largest joint change apart, both ends included."""
    dq = np.abs(np.asarray(q_to, dtype=float) - np.asarray(q_from, dtype=float))
    return np.linspace(0.0, 1.0, max(2, int(np.ceil(dq.max() / step)) + 1))


def held_path_fractions(q_from, q_to) -> np.ndarray:
    """Fractions s (n,) in [0, 1] at which a held block is checked against the other objects along the straight
    joint path q_from -> q_to (rad): path_fractions at HELD_PATH_STEP_RAD."""
    return path_fractions(q_from, q_to, HELD_PATH_STEP_RAD)


@dataclass(frozen=True)
class Prism:
    """An upright prism: its footprint as convex pieces (each (K, 2) mm in its own frame, their union the shape), from
    -half_height to +half_height mm along its own z, placed by pose (4, 4) (its centre and axes in the world, mm)."""

    pieces: tuple[np.ndarray, ...]
    half_height: float
    pose: np.ndarray
    name: str = "object"

    @property
    def radius(self) -> float:
        """Radius (mm) of a sphere about its centre that holds it, plus 1 mm (the quick test of held_depths)."""
        corners = np.vstack(self.pieces)
        return float(np.sqrt(np.max(np.sum(corners ** 2, axis=1)) + self.half_height ** 2)) + 1.0


def held_depths(moving: Prism, poses, other: Prism) -> np.ndarray:
    """How deep (mm) the prism `moving`, placed at each of poses (n, 4, 4) (its centre frame in the world; its own
    pose is not used), goes into the fixed prism `other`: (n,) > 0 penetration, <= 0 apart (-inf: too far apart to
    test). Separating axes over every pair of convex pieces (a union goes as deep as its deepest pair). The one
    geometry of the held-block rule (module notes)."""
    from armlab.sim.geometry import convex_penetration, prism_features  # armlab.sim's __init__ imports its arm,
    #                                                                     which imports this module: import on use
    poses = np.asarray(poses, float)
    centres = poses[:, :3, 3]
    depth = np.full(len(poses), -np.inf)
    near = np.flatnonzero(np.linalg.norm(centres - np.asarray(other.pose, float)[:3, 3], axis=1)
                          < moving.radius + other.radius)
    if not near.size:
        return depth
    a = [prism_features(p, moving.half_height, poses[near]) for p in moving.pieces]
    b = [prism_features(p, other.half_height, other.pose) for p in other.pieces]
    depth[near] = np.max([convex_penetration(x, y) for x in a for y in b], axis=0)
    return depth


def held_intrusion(depth, allowance_mm: float = HELD_CONTACT_TOL_MM) -> int | None:
    """The held-block rule (module notes): depth (n,) mm the held block goes into one other object at the path's
    samples (<= 0 or -inf: apart), the first at the start. Returns the first sample where it goes deeper than
    allowance_mm and than at the start, or None when the path keeps to the rule."""
    d = np.asarray(depth, dtype=float)
    if d.ndim != 1 or not len(d):
        raise ValueError(f"held_intrusion takes one depth per path sample (n,) mm, got shape {d.shape}")
    hits = np.flatnonzero(d > max(float(allowance_mm), d[0]) + 1e-9)
    return int(hits[0]) if hits.size else None


def _parts(Q, robot: RobotModel, gripper: GripperGeometry | None, opening_mm: float | None,
           held: Sequence[HeldBlock]) -> list[tuple[str, np.ndarray, bool]]:
    """(name, world points (n, k, 3) mm, is a contact part) of every checked part at the joint angles Q (n, 5)."""
    frames = link_frames(Q, robot, check_limits=False)               # (n, 7, 4, 4)
    T = frames[:, 6]                                                  # (n, 4, 4) tool poses
    points = frame_points(frames, robot)[:, 2:]                       # (n, 5, 3): shoulder ... tool point
    parts = [(name, points[:, i, None], False) for i, name in enumerate(LINK_POINTS)]
    if gripper is not None and opening_mm is not None:
        pads = gripper.pad_corners(T, opening_mm)                     # (n, 2, 8, 3)
        parts += [(name, pads[:, k], True) for k, name in enumerate(PAD_NAMES)]
    for block in held:
        local = _CUBE_CORNERS * block.edge_mm
        R, p = np.asarray(block.T_tool_block, float)[:3, :3], np.asarray(block.T_tool_block, float)[:3, 3]
        corners_tool = local @ R.T + p
        parts.append((block.name, np.einsum("nij,kj->nki", T[:, :3, :3], corners_tool) + T[:, None, :3, 3], True))
    return parts


def board_intrusion(q_from, q_to, clearance: BoardClearance, robot: RobotModel | None = None,
                    gripper: GripperGeometry | None = None, opening_mm: float | None = None,
                    held: Sequence[HeldBlock] = (),
                    physical: Callable[[np.ndarray], np.ndarray] | None = None) -> str | None:
    """Why the straight joint path q_from -> q_to (5,) rad takes a part below its floor, in words; None when clear.

    physical: maps commanded joint angles (n, 5) to the angles the links take (the simulator's sag and backlash);
    default: the commanded ones. The first part (links, then pads, then held blocks) to go below its floor is
    reported at its lowest point, with where along the move it first crosses the floor.
    """
    robot = robot or rx200()
    q0, q1 = np.asarray(q_from, dtype=float), np.asarray(q_to, dtype=float)
    s = path_fractions(q0, q1)
    Q = q0 + s[:, None] * (q1 - q0)
    Q = physical(Q) if physical is not None else Q
    for name, pts, contact in _parts(Q, robot, gripper, opening_mm, held):
        z = pts[..., 2]
        floor = clearance.contact_mm if contact else clearance.links_mm
        below = z < np.minimum(floor, z[0]) - 1e-9
        if below.any():
            first = int(np.flatnonzero(below.any(axis=1))[0])
            i, j = np.unravel_index(np.argmin(z), z.shape)
            x, y, zz = pts[i, j]
            z0 = z[0, j]
            under = f"the board's {floor:+.1f} mm floor for it" if z0 >= floor else \
                f"where it starts (z = {z0:.1f} mm, already under the board's {floor:+.1f} mm floor for it)"
            return (f"the {name} would go down to z = {zz:.1f} mm at ({x:.1f}, {y:.1f}) mm, {100 * s[i]:.0f}% of "
                    f"the way along the move, below {under} (it would first go below at {100 * s[first]:.0f}%)")
    return None


def check_move(q_from, q_to, moving_time: float | None = None, accel_time: float | None = None,
               robot: RobotModel | None = None, clearance: BoardClearance = REAL_CLEARANCE,
               gripper: GripperGeometry | None = None, opening_mm: float | None = None,
               held: Sequence[HeldBlock] = (),
               physical: Callable[[np.ndarray], np.ndarray] | None = None) -> tuple[float, float]:
    """Validate a move from q_from (where the arm is) to q_to (5,) rad; return the (moving_time, accel_time) s to
    send. Raises MotionRefused naming the problem (see the module notes), in this order: target, timing, board."""
    robot = robot or rx200()
    q_from = check_joints(q_from, robot, check_limits=False).astype(float)
    q_to = check_target(q_to, robot)
    times = check_timing(q_from, q_to, moving_time, accel_time, robot)
    hit = board_intrusion(q_from, q_to, clearance, robot, gripper, opening_mm, held, physical)
    if hit:
        raise refusal("collision with the board", hit)
    return times


def check_plan(q_start, segments: Sequence[Segment], robot: RobotModel | None = None,
               clearance: BoardClearance = REAL_CLEARANCE, gripper: GripperGeometry | None = None,
               physical: Callable[[np.ndarray], np.ndarray] | None = None) -> list[tuple[float, float]]:
    """Check every command of a plan, from q_start (5,) rad, before the first is sent: the (moving_time,
    accel_time) s of each, or MotionRefused naming the first segment that fails (its index and label) and why, so
    an impossible pick or place is refused before anything moves."""
    robot = robot or rx200()
    q = check_joints(q_start, robot, check_limits=False).astype(float)
    if q.shape != (5,):
        raise ValueError(f"q_start must be one joint vector (5,) rad, got shape {q.shape}")
    times = []
    for k, seg in enumerate(segments):
        if not isinstance(seg, Segment):
            raise ValueError(f"segment {k} must be a motion_safety.Segment, got {type(seg).__name__}")
        try:
            times.append(check_move(q, seg.q, seg.moving_time, seg.accel_time, robot, clearance, gripper,
                                    seg.opening_mm, seg.held, physical))
        except MotionRefused as e:
            what = f"segment {k}" + (f" ({seg.label})" if seg.label else "")
            raise MotionRefused(f"plan refused at {what} of {len(segments)}: {e}") from None
        q = np.asarray(seg.q, dtype=float)
    return times


def arm_reach_mm(robot: RobotModel | None = None) -> float:
    """The arm's reach (mm): shoulder joint to tool point with the arm straight (the sum of its link lengths)."""
    robot = robot or rx200()
    P = joint_positions(np.asarray(robot.home, float), robot)[2:]     # shoulder, elbow, wrist, wrist_rotate, tool
    return float(np.sum(np.linalg.norm(np.diff(P, axis=0), axis=1)))


def _footprint(xy: np.ndarray, edge_mm: float, yaw: float) -> np.ndarray:
    """Corners (4, 2) world mm of a square of edge_mm centred at xy turned by yaw (all at xy for edge 0)."""
    c, s = np.cos(yaw), np.sin(yaw)
    half = np.array([[-1, -1], [1, -1], [1, 1], [-1, 1]], float) * edge_mm / 2
    return xy + half @ np.array([[c, s], [-s, c]])


def _overlaps_box(corners: np.ndarray, half: tuple[float, float]) -> bool:
    """True when the convex quadrilateral `corners` (4, 2) overlaps the axis-aligned box |x| <= half[0], |y| <=
    half[1] (separating axes: the box's two and the quadrilateral's edge normals)."""
    box = np.array([[-half[0], -half[1]], [half[0], -half[1]], [half[0], half[1]], [-half[0], half[1]]])
    edges = np.diff(np.vstack([corners, corners[:1]]), axis=0)
    axes = [np.array([1.0, 0.0]), np.array([0.0, 1.0])] + [np.array([-e[1], e[0]]) for e in edges
                                                          if np.hypot(*e) > 1e-12]
    for a in axes:
        p, q = corners @ a, box @ a
        if p.max() < q.min() or q.max() < p.min():
            return False
    return True


def placement_problem(position, edge_mm: float = 0.0, yaw: float = 0.0, lab: LabConfig | None = None,
                      robot: RobotModel | None = None, reach: bool = True) -> str | None:
    """Why a block of edge_mm (0: a point, e.g. a click) turned by yaw rad cannot be put with its bottom-face centre
    at position (x, y, z) world mm, in words (module notes: off the board, on the robot's base plate, out of reach;
    reach=False: the board and the plate only, for a point that is not a placement yet); None when the spot is
    allowed. ValueError for malformed input."""
    try:
        p = np.asarray(position, dtype=float)
        edge_mm, yaw = float(edge_mm), float(yaw)
    except (TypeError, ValueError):
        p = np.full(0, np.nan)
    if p.shape != (3,) or not np.all(np.isfinite(p)):
        raise ValueError(f"a placement position must be 3 finite numbers (x, y, z world mm), got {position!r}")
    if not (np.isfinite(edge_mm) and edge_mm >= 0 and np.isfinite(yaw)):
        raise ValueError(f"a placement needs a finite edge >= 0 mm and a finite yaw (rad), got {edge_mm!r}, {yaw!r}")
    lab = lab or lab_config()
    corners = _footprint(p[:2], float(edge_mm), float(yaw))
    where = f"({p[0]:.0f}, {p[1]:.0f}) mm"
    if not np.all(lab.on_board(corners)):
        what = "is off the board" if not lab.on_board(p[:2]) else \
            f"is too close to the board's edge for a {edge_mm:g} mm block"
        return (f"{where} {what} (x in [{lab.board_x[0]:g}, {lab.board_x[1]:g}], y in "
                f"[{lab.board_y[0]:g}, {lab.board_y[1]:g}] mm)")
    hx, hy = (h + PLACE_BASE_MARGIN_MM for h in lab.robot_base_half_mm)
    if _overlaps_box(corners, (hx, hy)):
        what = "is on the robot's base plate" if lab.on_robot_base(p[:2], PLACE_BASE_MARGIN_MM) else \
            f"is too close to the robot's base plate for a {edge_mm:g} mm block"
        return (f"{where} {what} (the plate and a {PLACE_BASE_MARGIN_MM:g} mm margin: |x| <= {hx:g}, "
                f"|y| <= {hy:g} mm)")
    if not reach:
        return None
    robot = robot or rx200()
    shoulder = joint_positions(np.asarray(robot.home, float), robot)[2]
    nearest = np.array([p[0], p[1], np.clip(shoulder[2], p[2], p[2] + edge_mm)])    # of the block's height span
    reach, far = arm_reach_mm(robot), float(np.linalg.norm(nearest - shoulder))
    if far > reach:
        return (f"{where} is out of the arm's reach: {far:.0f} mm from the shoulder joint, the straight arm "
                f"reaches {reach:.0f} mm")
    return None


def check_placement(position, edge_mm: float = 0.0, yaw: float = 0.0, lab: LabConfig | None = None,
                    robot: RobotModel | None = None) -> None:
    """MotionRefused (category 'placement') saying why when placement_problem finds one; None when allowed."""
    problem = placement_problem(position, edge_mm, yaw, lab, robot)
    if problem:
        raise refusal("placement", problem)

"""Pick and place plans: transit above the target, open, descend, grasp or release, lift.

Heights (world mm):
- grasp: the tool point (the centre of the finger pads) `grasp_depth` below the block's top face: at the block's
  centre (edge / 2), as the lab did ("half the block height"), unless that would bring the finger tips (half a pad,
  8 mm, beyond the tool point: armlab.gripper_geometry.GRIPPER) within 10 mm of whatever the block stands on (real
  arms sag 5-15 mm at long reach): then edge - 18 mm (7 mm for the 25 mm cubes; the 38 mm cubes are grasped at their
  centre). A held block's bottom face is edge - grasp_depth below the tool point.
- place: the held block's bottom-face centre at the requested position, so the tool point goes to
  position z + edge - grasp_depth (= z + edge / 2 for a grasp at the centre).
- transit: a straight rise from the start to height z_t (when lower), then a joint-space move to the hover point
  straight above the target at z_t, where z_t starts at `clearance` above the top of the block being picked or of the
  block once placed (so the empty gripper clears it after the lift), then is raised until the
  sampled transit clears every obstacle near the path (transit.transit_clearance: wrist and tool points
  `clearance` above the tops of the obstacles they pass, a held block lifted over them). A height out of reach is
  refused with Unreachable naming the obstacle.
The descent and lift are the kit's descent (planning.descent: a straight line in the instructor's kit, a joint chord
in the student release) at the grasp's pitch and roll (grasp.choose_grasp: top-down with the roll across the block's
faces, or the steepest pitch the descent can be made at); a place of a block held tilted in the tool frame (gripped at
another pitch) comes down where it can at the pitch and roll that let it go level (grasp.level_pitch_roll).

Camera clear: the arm stands upright over its base (CAMERA_CLEAR_POSE: elbow -90 deg, gripper pointing up). Seen from
the overhead camera (about 1 m up at y = 337 mm), everything in that pose projects onto the board behind the
robot's own base (y < 60 mm along x = 0, see the tests), so it hides none of the board in front of the robot where
blocks start, and it stays well above any stack. The manufacturer's sleep pose instead leaves the gripper 74 mm above
the board at y = 123 mm, in front of the base, where it hides blocks and can hit stacks.
"""

from __future__ import annotations

import numpy as np

from armlab import kinematics, motion_safety
from armlab.gripper_geometry import GRIPPER
from armlab.kinematics import Unreachable
from armlab.robot import RobotModel, rx200

from .descent import approach_reachable, descend
from .grasp import TOP_DOWN, choose_grasp, inner_limits, level_pitch_roll, steepest_pitch_inside
from .plan import GripperStep, MoveStep, Plan
from .trajectory import cartesian_line, check_point, joint_move, reverse
from .transit import DEFAULT_CLEARANCE_MM, GRIPPER_RADIUS_MM, Obstacle, as_obstacles, transit_clearance

__all__ = ["CAMERA_CLEAR_POSE", "default_grasp_depth", "grasp_height", "place_tool_height", "plan_pick", "plan_place",
           "plan_pick_place", "plan_camera_clear", "tilted_release_lift"]

CAMERA_CLEAR_POSE = np.array([0.0, 0.0, -np.pi / 2, 0.0, 0.0])
FINGERTIP_MM = GRIPPER.fingertip_mm   # finger tips beyond the tool point along the approach (half a finger pad)
TIP_MARGIN_MM = 10.0        # finger tips at least this far above what the grasped block stands on
_MAX_RAISES = 8
LOW_HOVER_MM = GRIPPER.fingertip_mm + 7.0   # a place may hover this little above the placed block's top (finger tips
                                            # 7 mm over it after the lift) to come down with the yaw
_LOW_HOVER_STEP_MM = 5.0
_OWN_COLUMN_MM = 5.0        # obstacles centred this close to a pick's target are the picked block's own column


def _check_edge_depth(edge: float, grasp_depth: float | None) -> float:
    if not np.isfinite(edge) or edge <= 0:
        raise ValueError(f"block edge must be a positive length in mm, got {edge}")
    depth = default_grasp_depth(edge) if grasp_depth is None else float(grasp_depth)
    if not 0 < depth <= edge:
        raise ValueError(f"grasp_depth must be in (0, edge] = (0, {edge}] mm below the top face, got {grasp_depth}")
    return depth


def default_grasp_depth(edge: float) -> float:
    """Tool point depth (mm) below a cube's top face: its centre, or higher so the finger tips stay TIP_MARGIN_MM
    above the surface under the cube.
    """
    return float(min(edge / 2, edge - FINGERTIP_MM - TIP_MARGIN_MM))


def grasp_height(top_z: float, edge: float, grasp_depth: float | None = None) -> float:
    """Tool point height (world mm) to grasp a block whose top face is at top_z: top_z - grasp_depth.
    """
    return float(top_z - _check_edge_depth(edge, grasp_depth))


def place_tool_height(place_z: float, edge: float, grasp_depth: float | None = None) -> float:
    """Tool point height (world mm) that puts a held block's bottom face at place_z: place_z + edge - grasp_depth.
    """
    return float(place_z + edge - _check_edge_depth(edge, grasp_depth))


def _near_segment(obstacles: list[Obstacle], a: np.ndarray, b: np.ndarray) -> list[Obstacle]:
    """Obstacles whose footprint comes within the gripper's radius of the horizontal segment a -> b."""
    ab = b[:2] - a[:2]
    out = []
    for o in obstacles:
        ap = np.array([o.x, o.y]) - a[:2]
        u = np.clip(ap @ ab / max(ab @ ab, 1e-12), 0.0, 1.0)
        if np.linalg.norm(ap - u * ab) < o.radius + GRIPPER_RADIUS_MM:
            out.append(o)
    return out


def _tool_pitch_roll(q: np.ndarray, robot: RobotModel) -> tuple[np.ndarray, float, float]:
    """Tool point (3,) mm and the (pitch, roll) rad with fk(q) = tool_orientation(heading of the point, pitch, roll)."""
    T = kinematics.fk(q, robot)
    p = T[:3, 3]
    M = kinematics.tool_orientation(np.arctan2(p[1], p[0]), 0.0, 0.0).T @ T[:3, :3]   # = Ry(pitch) Rx(roll)
    return p, float(np.arctan2(-M[2, 0], M[0, 0])), float(np.arctan2(-M[1, 2], M[1, 1]))


def _rise(q0: np.ndarray, z_t: float, scaling: str, robot: RobotModel):
    """Lift the tool from q0 to height z_t above the same point: a Cartesian segment at the current pitch and roll
    when the arm can keep them all the way up, else a joint move to the steepest pitch that reaches the point above
    (wrist_angle runs out when a top-down tool rises near the base), kept grasp.LIMIT_MARGIN_RAD inside the joint
    limits where it can. None when the tool is already high enough or
    q0 is not a pose the closed-form IK reproduces (e.g. the tool over the waist axis)."""
    p, pitch, roll = _tool_pitch_roll(q0, robot)
    if p[2] >= z_t or np.hypot(p[0], p[1]) < 1.0:
        return None
    up = np.array([p[0], p[1], z_t])
    try:
        seg = cartesian_line(p, up, pitch, roll, current=q0, robot=robot)
        return seg if np.abs(seg.start - q0).max() <= 1e-6 else None
    except Unreachable:
        steepest, model = steepest_pitch_inside(up, roll, max_pitch=min(pitch, np.pi / 2), robot=robot)
        move = joint_move(q0, kinematics.ik(up, steepest, roll, current=q0, robot=model)[0], scaling, robot=robot)
        q, _ = move.sample(np.linspace(0.0, move.duration, 200))
        low = kinematics.joint_positions(q)[:, 4:, 2].min(axis=0) - kinematics.joint_positions(q0)[4:, 2]
        if low.min() < -1.0:
            raise Unreachable(f"rising from ({p[0]:.1f}, {p[1]:.1f}, {p[2]:.1f}) mm the wrist or tool would first dip "
                              f"{-low.min():.1f} mm") from None
        return move


_RELEASE_TRIES = 4            # plans made at most for a tilted place's release height (plan_place)
_RELEASE_OVERSHOOT_MM = 0.25  # each new try raises the place this much above the drop it must cover


def tilted_release_lift(edge: float, pitch: float) -> float:
    """How far (mm) a held cube's lowest edge hangs below its bottom-face centre when the tool is at `pitch` rad
    (pi/2: top-down, 0 mm): the cube turns with the tool by pi/2 - pitch, so that edge sits (edge / 2) |cos(pitch)|
    lower. A tilted place is raised by this much, so that the edge, not the face's centre, arrives at the target."""
    return float(edge / 2 * abs(np.cos(pitch)))


def _line_or_none(p0: np.ndarray, p1: np.ndarray, pitch: float, roll: float, robot: RobotModel):
    """The descent p0 -> p1 (mm) at pitch and roll (rad; planning.descent), or None where it cannot be made (it
    would switch IK branch on the way, e.g. where choose_grasp's branch is one the limits with a margin allow)."""
    try:
        return descend(p0, p1, pitch, roll, robot=robot)
    except Unreachable:
        return None


def _chosen_descent(target: np.ndarray, yaw: float, z_t: float, low_hover: float | None, action: str,
                    others: list[Obstacle], robot: RobotModel):
    """(hover (3,) mm, lowered, descent) at choose_grasp's pitch and roll for the yaw from the transit height z_t, or
    from a lower hover (down to low_hover) where that comes down steeper (_approach's notes)."""
    neighbours = others if action == "close" else ()      # a pick's open pads keep clear of them
    grasp = choose_grasp(target, yaw, approach_z=z_t, robot=robot, obstacles=neighbours)
    best = None
    if not grasp.top_down and low_hover is not None:       # a shorter descent keeps the yaw
        for z in np.arange(z_t - _LOW_HOVER_STEP_MM, low_hover - 1e-9, -_LOW_HOVER_STEP_MM):
            low = choose_grasp(target, yaw, approach_z=z, robot=robot, obstacles=neighbours)
            if low.pitch > grasp.pitch + 1e-9:             # steeper: less tilt, more of the yaw kept
                hover = np.array([target[0], target[1], z])
                line = _line_or_none(hover, target, low.pitch, low.roll, robot)
                if line is not None:
                    grasp, best = low, (hover, True, line)
                    if low.top_down:
                        break
    if best is not None:
        return best
    hover = np.array([target[0], target[1], z_t])
    return hover, False, descend(hover, target, grasp.pitch, grasp.roll, robot=robot)


def _posed_descent(target: np.ndarray, z_t: float, low_hover: float | None, pitch: float, roll: float,
                   robot: RobotModel):
    """(hover (3,) mm, lowered, descent) down to target at a given pitch and roll (rad): from the transit height z_t,
    else from the highest lower hover (in _LOW_HOVER_STEP_MM steps down to low_hover) it can be made from, with the
    margin from the joint limits first (grasp module notes). Raises Unreachable when there is none."""
    hovers = [z_t] + ([] if low_hover is None else list(np.arange(z_t - _LOW_HOVER_STEP_MM, low_hover - 1e-9,
                                                                   -_LOW_HOVER_STEP_MM)))
    for model in (inner_limits(robot), robot):
        for z in hovers:
            hover = np.array([target[0], target[1], z])
            if approach_reachable(target, z, pitch, roll, model):
                line = _line_or_none(hover, target, pitch, roll, robot)
                if line is not None:
                    return hover, bool(z < z_t), line
    raise Unreachable(f"no descent at pitch {np.degrees(pitch):.1f} deg, roll {np.degrees(roll):.1f} deg comes down "
                      f"to ({target[0]:.1f}, {target[1]:.1f}, {target[2]:.1f}) mm from a hover between "
                      f"{hovers[-1]:.1f} and {z_t:.1f} mm")


def _approach(q_start, target: np.ndarray, yaw: float, floor_z: float, held_below: float, action: str,
              obstacles, clearance: float, scaling: str, robot: RobotModel, what: str,
              low_hover: float | None = None, own_column: bool = False,
              pose: tuple[float, float] | None = None) -> Plan:
    """transit to the hover point over target, [open], descend, open/close, lift back (see the module notes).

    floor_z: the top (mm) the empty tool must clear at the hover point when the plan ends (the picked block's top, or
    the placed block's top); held_below: how far a held block hangs below the tool point during the transit.
    low_hover: when the descent from the transit height cannot be top-down, the lowest hover height (mm)
    from which shorter descents are tried (in _LOW_HOVER_STEP_MM steps): the first top-down one, else the steepest.
    own_column: the obstacles standing at the target (the block being picked, the stack under it) only keep the
    transit's tool from going lower over them than the hover point it ends at (the others: `clearance`), so a low
    hover over the picked block is not refused because of that block itself.
    pose: the descent's (pitch, roll) rad, fixed (_posed_descent: a level release) instead of chosen for the yaw.
    """
    if not np.isfinite(clearance) or clearance < 0:
        raise ValueError(f"clearance must be a non-negative length in mm, got {clearance}")
    if not np.isfinite(yaw):
        raise ValueError(f"yaw must be finite (rad), got {yaw}")
    q0 = kinematics.check_joints(q_start, robot)
    if q0.shape != (5,):
        raise ValueError(f"q_start must have shape (5,) (rad), got {q0.shape}")
    obs = as_obstacles(obstacles)
    column = [o for o in obs if own_column and np.hypot(o.x - target[0], o.y - target[1]) < _OWN_COLUMN_MM
              and o.top <= floor_z + 1.0]
    others = [o for o in obs if all(o is not c for c in column)]
    z_t = max(floor_z + clearance, float(target[2]))
    near = _near_segment(others, kinematics.fk(q0, robot)[:3, 3], target)
    if near:
        z_t = max(z_t, max(o.top for o in near) + clearance + held_below)
    for _ in range(_MAX_RAISES + 1):
        try:
            if pose is None:
                hover, lowered, down = _chosen_descent(target, yaw, z_t, low_hover, action, others, robot)
            else:
                hover, lowered, down = _posed_descent(target, z_t, low_hover, *pose, robot)
            rise = _rise(q0, z_t, scaling, robot)
        except Unreachable as e:
            raise Unreachable(f"{what}: cannot move straight up or down to the transit height {z_t:.1f} mm: "
                              f"{e}") from None
        transit = joint_move(q0 if rise is None else rise.end, down.start, scaling, robot=robot)
        c = transit_clearance(transit, others, clearance, held_below)   # the rise only goes up from where the arm is
        if c.clear and column:
            c = transit_clearance(transit, column, min(clearance, hover[2] - floor_z), held_below)
        if c.clear:
            break
        o = c.obstacle
        if lowered:                  # the lower hover passes too close to a neighbour: tilt from z_t instead
            low_hover = None
            continue
        z_t += c.deficit + 1.0
    else:
        raise Unreachable(f"{what}: no transit height up to {z_t:.1f} mm clears the obstacle at ({o.x:.1f}, "
                          f"{o.y:.1f}) mm (top {o.top:.1f} mm) by {clearance:.0f} mm")
    steps = ([] if rise is None else [MoveStep(rise, "rise")]) + [MoveStep(transit, "transit")]
    if action == "close":
        steps.append(GripperStep("open", "open before grasping"))
    steps += [MoveStep(down, "descend"), GripperStep(action, "grasp" if action == "close" else "release"),
              MoveStep(reverse(down), "lift")]
    return Plan(tuple(steps))


def plan_pick(q_start, top, yaw: float, edge: float, obstacles=(), clearance: float = DEFAULT_CLEARANCE_MM,
              grasp_depth: float | None = None, scaling: str = "trapezoid",
              robot: RobotModel | None = None) -> Plan:
    """Plan to pick the block whose top-face centre is `top` (3,) world mm, yaw rad, cube edge mm, from q_start (5,).

    Steps: transit (joint move) to the hover point, open, descend (planning.descent) to the grasp height, close,
    lift (the descent reversed) back to the hover point. obstacles: everything standing on the board (the target may
    be included).
    Where the descent from the transit height cannot be top-down (at long reach), a lower hover (down to
    LOW_HOVER_MM above the block's top) that comes down top-down, or else steeper, is preferred, as for plan_place:
    the steeper the grasp, the more of the block's yaw the pads can meet square (grasp.tilted_roll).
    """
    robot = robot or rx200()
    top = check_point(top, "block top")
    target = np.array([top[0], top[1], grasp_height(top[2], edge, grasp_depth)])
    return _approach(q_start, target, yaw, top[2], 0.0, "close", obstacles, clearance, scaling, robot,
                     f"picking the block at ({top[0]:.1f}, {top[1]:.1f}, {top[2]:.1f}) mm",
                     low_hover=top[2] + LOW_HOVER_MM, own_column=True)


def plan_place(q_start, position, edge: float, yaw: float = 0.0, obstacles=(),
               clearance: float = DEFAULT_CLEARANCE_MM, grasp_depth: float | None = None, scaling: str = "trapezoid",
               robot: RobotModel | None = None, held_in_tool=None) -> Plan:
    """Plan to put the held block's bottom-face centre at `position` (3,) world mm with yaw rad, from q_start (5,).
    A spot the placement rule refuses (motion_safety.check_placement: off the board, on the robot's base plate, out
    of reach) raises MotionRefused before anything is planned.

    Steps: transit to the hover point (the held block lifted `clearance` over everything near the path), descend
    (planning.descent) until the tool point is at place_tool_height, open, lift. obstacles: everything on the board
    except the held block. The yaw is reached exactly for top-down placing, so when the descent from the transit height
    cannot be top-down a shorter one from a lower hover point (down to LOW_HOVER_MM above the placed block, the transit
    still checked against every obstacle) is preferred; only when none works is the place tilted, which leaves the block
    square to the fingers: yaw = heading (mod 90 deg), up to 45 deg from the requested yaw (grasp module notes), and
    releases it tilted_release_lift(edge, pitch) higher, so that its lowest edge, not its bottom face's centre, comes
    down no lower than position's height.
    held_in_tool: the held cube's pose in the tool frame T_tool_block (4, 4) mm (its centre), as the grasp left it
    (e.g. tilted with the tool of a tilted pick); when given, the release is aimed with it instead: the plan is
    redone with the tool target shifted until, at the end of the planned descent, the cube's centre is over
    position's x, y and its lowest corner at position's height (within _AIM_TOL_MM, at most _RELEASE_TRIES plans).
    A cube held tilted (more than _LEVEL_TOL_RAD from level under a top-down tool: gripped at another pitch) is let go
    level: the descent is made at grasp.level_pitch_roll's pitch and roll (the pick's own, for a cube gripped level),
    which puts its faces level and its bottom face at position's height; the yaw is then the one the cube had to the
    arm plane at its grasp, not `yaw`. Only where no such descent exists (out of reach at that pitch and roll, from
    any hover down to LOW_HOVER_MM above the placed block, or its transit cannot clear the obstacles) is the cube
    placed as without levelling, and let go tilted, its lowest corner aimed at position's height: it lands on that
    edge and tips flat, up to armlab.sim.physics.rest.tipping_shift_mm off.
    """
    robot = robot or rx200()
    position = check_point(position, "place position")
    depth = _check_edge_depth(edge, grasp_depth)
    motion_safety.check_placement(position, edge, yaw, robot=robot)
    if held_in_tool is not None:
        T_tool_block = _check_pose(held_in_tool, "held_in_tool")
        level = level_pitch_roll(T_tool_block[:3, :3])
        if level is not None and level[0] < TOP_DOWN - _LEVEL_TOL_RAD:
            try:
                return _aimed_place(q_start, position, edge, depth, yaw, obstacles, clearance, scaling, robot,
                                    T_tool_block, level)
            except Unreachable:
                pass                 # no level release: the cube is let go tilted, its lowest corner aimed
        return _aimed_place(q_start, position, edge, depth, yaw, obstacles, clearance, scaling, robot, T_tool_block)
    lift = 0.0
    for attempt in range(_RELEASE_TRIES):
        # a tilted descent's pitch depends on the hover height the plan settles on: plan, then again with the place
        # raised by the lowest edge's drop at that pitch until the drop is covered (the last try: the most any pitch
        # can drop it, edge / 2)
        p = position + [0.0, 0.0, lift]
        target = np.array([p[0], p[1], place_tool_height(p[2], edge, depth)])
        plan = _approach(q_start, target, yaw, p[2] + edge, edge - depth, "open", obstacles, clearance, scaling,
                         robot, f"placing at ({position[0]:.1f}, {position[1]:.1f}, {position[2]:.1f}) mm",
                         low_hover=p[2] + edge + LOW_HOVER_MM)
        need = tilted_release_lift(edge, next(s.trajectory for s in plan.steps if s.label == "descend").pitch)
        if need <= lift + 1e-9:
            break
        lift = need + _RELEASE_OVERSHOOT_MM if attempt < _RELEASE_TRIES - 2 else edge / 2
    return plan


_AIM_TOL_MM = 0.1                # an aimed release is redone until it is off by at most this much per axis
_LEVEL_TOL_RAD = np.radians(0.5)  # a held cube this close to level under a top-down tool is placed as one held level
_CUBE_CORNERS = np.array([[x, y, z] for x in (-0.5, 0.5) for y in (-0.5, 0.5) for z in (-0.5, 0.5)])


def _check_pose(T, name: str) -> np.ndarray:
    T = np.asarray(T, dtype=float)
    if T.shape != (4, 4) or not np.all(np.isfinite(T)):
        raise ValueError(f"{name} must be a finite (4, 4) transform (mm), got shape {T.shape}")
    return T


def _aimed_place(q_start, position: np.ndarray, edge: float, depth: float, yaw: float, obstacles, clearance: float,
                 scaling: str, robot: RobotModel, T_tool_block: np.ndarray,
                 pose: tuple[float, float] | None = None) -> Plan:
    """plan_place aimed with the held cube's pose in the tool frame (plan_place's held_in_tool); pose: the descent's
    (pitch, roll) rad, fixed (a level release), else chosen for the yaw. Raises Unreachable when it cannot be made."""
    offset = np.zeros(3)
    for _ in range(_RELEASE_TRIES):
        p = position + offset
        target = np.array([p[0], p[1], place_tool_height(p[2], edge, depth)])
        plan = _approach(q_start, target, yaw, p[2] + edge, edge - depth, "open", obstacles, clearance, scaling,
                         robot, f"placing at ({position[0]:.1f}, {position[1]:.1f}, {position[2]:.1f}) mm",
                         low_hover=p[2] + edge + LOW_HOVER_MM, pose=pose)
        cube = kinematics.fk(next(s.trajectory for s in plan.steps if s.label == "descend").end, robot) @ T_tool_block
        lowest = (_CUBE_CORNERS * edge @ cube[:3, :3].T + cube[:3, 3])[:, 2].min()
        miss = np.array([position[0] - cube[0, 3], position[1] - cube[1, 3], position[2] - lowest])
        if np.abs(miss).max() <= _AIM_TOL_MM:
            break
        offset += miss
    return plan


def plan_pick_place(q_start, top, yaw: float, edge: float, position, place_yaw: float = 0.0, obstacles=(),
                    clearance: float = DEFAULT_CLEARANCE_MM, grasp_depth: float | None = None,
                    scaling: str = "trapezoid", robot: RobotModel | None = None) -> Plan:
    """plan_pick then plan_place; the picked block (the obstacle whose top matches `top` within 1 mm) is left out
    of the obstacles for the place."""
    robot = robot or rx200()
    pick = plan_pick(q_start, top, yaw, edge, obstacles, clearance, grasp_depth, scaling, robot)
    t = np.asarray(top, float)
    rest = [o for o in as_obstacles(obstacles) if np.abs(np.array([o.x, o.y, o.top]) - t).max() > 1.0]
    place = plan_place(pick.end, position, edge, place_yaw, rest, clearance, grasp_depth, scaling, robot)
    return pick.then(place)


def plan_camera_clear(q_start, obstacles=(), clearance: float = DEFAULT_CLEARANCE_MM, held_below: float = 0.0,
                      scaling: str = "trapezoid", robot: RobotModel | None = None) -> Plan:
    """Joint move from q_start (5,) to CAMERA_CLEAR_POSE, refused (Unreachable) if it would pass too low over an
    obstacle (held_below: how far a held block hangs below the tool point, mm)."""
    robot = robot or rx200()
    move = joint_move(q_start, CAMERA_CLEAR_POSE, scaling, robot=robot)
    c = transit_clearance(move, as_obstacles(obstacles), clearance, held_below)
    if not c.clear:
        o = c.obstacle
        raise Unreachable(f"moving to the camera-clear pose would pass {c.deficit:.1f} mm too low over the obstacle "
                          f"at ({o.x:.1f}, {o.y:.1f}) mm (top {o.top:.1f} mm): lift the arm first")
    return Plan((MoveStep(move, "camera clear"),))

"""A pick or place plan checked whole before its first command: the plan -> armlab.motion_safety segments with the
pads' opening and the held block along it, under the task layer's sag model, plus the held block against the blocks
the task layer knows (its detections).

What the arms refuse mid-plan, checked here first (MotionRefused names the step, before anything is sent):
- every command GuardedArm would send (sag.command of the planned joints) by motion_safety.check_plan: joint limits,
  time profile, velocity limits; the board clearance on the commanded angles with the real arm's link margin
  (REAL_CLEARANCE), and on the angles the task layer predicts the links take (sag.physical of the commands) with the
  simulator's floors (SIM_CLEARANCE), the contact floor (pads, held block) PRECHECK_MARGIN_MM stricter to cover the
  sag model's residual;
- the held block against the known blocks along every move it is carried, with the simulator's own geometry
  (motion_safety.held_depths: upright prisms by separating axes) and rule (motion_safety.held_intrusion): the held
  cube at its pose in the tool frame, each known block an upright prism standing on the board (a detection: its
  top-face centre, yaw and edge; an Obstacle from an earlier place: the polygon around its cylinder), with
  PRECHECK_MARGIN_MM less allowance (none: the simulator allows 0.5 mm, the margin covers detection error).
Every pose is the manufacturer's model (kinematics.fk_pox), never the DH chain built on the student's exercise.
The picked block itself and whatever stands in its column (the stack it comes from) are not obstacles to the lift.
Units: mm, rad; world (board) frame; tool frame = ee_gripper_link.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np

from armlab import kinematics, motion_safety, planning
from armlab.gripper_geometry import GRIPPER, GripperGeometry
from armlab.planning import Obstacle
from armlab.station.contract import MotionRefused
from armlab.transforms import homogeneous, rot_z, wrap_quarter

from .guard import GuardedArm

__all__ = ["PRECHECK_MARGIN_MM", "KnownBox", "known_boxes", "known_prism", "held_prism", "held_pose_at_grasp",
           "plan_segments", "check_whole_plan"]

PRECHECK_MARGIN_MM = 0.5        # the contact floor and the held block's clearance are this much stricter than the sim


@dataclass(frozen=True)
class KnownBox:
    """An upright obstacle standing on the board: centre x, y (mm), top z (mm), half side (mm) and yaw (rad); yaw
    None: a cylinder of radius `half`."""

    x: float
    y: float
    top: float
    half: float
    yaw: float | None


def known_boxes(known, exclude_xy=None, exclude_radius: float = 0.0) -> list[KnownBox]:
    """The task layer's known objects (detection Blocks, planning Obstacles) as KnownBoxes, leaving out those whose
    centre is within exclude_radius mm (or their own half side) of exclude_xy (2,) mm: the column a block is picked
    from (a stack, or a second detection of the picked block's own side face)."""
    out = []
    for k in known:
        if isinstance(k, Obstacle):
            box = KnownBox(k.x, k.y, k.top, k.radius, None)
        else:
            p = np.asarray(k.position, float)
            box = KnownBox(float(p[0]), float(p[1]), float(p[2]), float(k.edge_mm) / 2, float(k.yaw))
        near = exclude_xy is not None and np.hypot(box.x - exclude_xy[0], box.y - exclude_xy[1]) < max(box.half,
                                                                                                     exclude_radius)
        if not near:
            out.append(box)
    return out


def held_pose_at_grasp(q_grasp, top, yaw: float, edge: float) -> np.ndarray:
    """T_tool_block (4, 4) mm of a cube of `edge` mm whose top-face centre is `top` (3,) world mm with yaw rad, held by
    the tool at the planned joints q_grasp (5,) rad, as the closing pads leave it: they push it to the middle of the
    gap (its centre on the tool's z-x plane, y = 0 in the tool frame) and turn it until a face lies flat on a pad
    (its yaw the closing direction's heading, modulo 90 deg: a detection's yaw error is gone once it is held). Its
    height and its place along the approach are the detection's: the pads do not move it that way."""
    T_tool = kinematics.fk_pox(np.asarray(q_grasp, float))
    R_tool, t_tool = T_tool[:3, :3], T_tool[:3, 3]
    centre = R_tool.T @ (np.asarray(top, float) - [0.0, 0.0, edge / 2] - t_tool)    # tool frame
    centre[1] = 0.0
    closing = R_tool[:, 1]
    squared = float(yaw) + float(wrap_quarter(np.arctan2(closing[1], closing[0]) - float(yaw)))
    c, s = np.cos(squared), np.sin(squared)
    R = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    return homogeneous(R_tool.T @ R, centre)


def plan_segments(plan: planning.Plan, arm: GuardedArm, opening_mm: float, held: Sequence[motion_safety.HeldBlock],
                  grasped: motion_safety.HeldBlock | None = None,
                  gripper: GripperGeometry = GRIPPER) -> list[tuple[motion_safety.Segment, np.ndarray]]:
    """Every command of `plan` as (motion_safety.Segment of what the guarded arm would send: the sag-compensated
    command and its stretched times, GuardedArm.command_for; the planned q): the pads at opening_mm with `held`
    until a gripper step changes them (open: max opening, nothing held; close: the pads on `grasped`, then held)."""
    out = []
    opening, carried = float(opening_mm), tuple(held)
    last = arm.sag.command(np.asarray(plan.start, float), arm.robot)
    for k, step in enumerate(plan.steps):
        if isinstance(step, planning.GripperStep):
            if step.action == "open":
                opening, carried = gripper.max_opening_mm, ()
            elif grasped is not None:
                opening, carried = grasped.edge_mm, (grasped,)
            continue
        for i, wp in enumerate(step.trajectory.waypoints()):
            label = f"step {k} ({step.label}), command {i}"
            try:
                q_cmd, T, Ta = arm.command_for(wp.q, [last], wp.moving_time, wp.accel_time)
            except MotionRefused as e:
                raise MotionRefused(f"{label}: {e}") from None
            out.append((motion_safety.Segment(q_cmd, T, Ta, opening, carried, label), np.asarray(wp.q, float)))
            last = q_cmd
    return out


_CYLINDER_SIDES = 16             # a known cylinder (an earlier place's Obstacle) as the polygon around it


def known_prism(box: KnownBox) -> motion_safety.Prism:
    """A known box as the held-block rule's upright prism (motion_safety.Prism): standing on the board up to its top;
    a cylinder (yaw None) as the regular polygon of _CYLINDER_SIDES sides around it."""
    if box.yaw is None:
        a = np.arange(_CYLINDER_SIDES) * 2 * np.pi / _CYLINDER_SIDES
        piece = np.column_stack([np.cos(a), np.sin(a)]) * box.half / np.cos(np.pi / _CYLINDER_SIDES)
    else:
        piece = np.array([[-1.0, -1.0], [1.0, -1.0], [1.0, 1.0], [-1.0, 1.0]]) * box.half
    pose = homogeneous(rot_z(0.0 if box.yaw is None else box.yaw), [box.x, box.y, box.top / 2])
    return motion_safety.Prism((piece,), box.top / 2, pose, f"the known block at ({box.x:.1f}, {box.y:.1f}) mm "
                                                            f"(top {box.top:.1f} mm)")


def held_prism(block: motion_safety.HeldBlock) -> motion_safety.Prism:
    """A held cube as the held-block rule's prism (its pose is given per path sample)."""
    piece = np.array([[-1.0, -1.0], [1.0, -1.0], [1.0, 1.0], [-1.0, 1.0]]) * block.edge_mm / 2
    return motion_safety.Prism((piece,), block.edge_mm / 2, np.eye(4), block.name)


def _held_hits(q0, q1, held: Sequence[motion_safety.HeldBlock], boxes: Sequence[KnownBox]) -> str | None:
    """Why carrying `held` along the straight planned joint path q0 -> q1 would push it into a known box, or None:
    the simulator's geometry (motion_safety.held_depths) and rule (held_intrusion), PRECHECK_MARGIN_MM less
    allowance."""
    if not held or not boxes:
        return None
    s = motion_safety.held_path_fractions(q0, q1)
    T = kinematics.fk_pox(q0 + s[:, None] * (q1 - q0), check_limits=False)             # (n, 4, 4)
    for block in held:
        poses = T @ np.asarray(block.T_tool_block, float)                               # (n, 4, 4) cube poses
        for box in boxes:
            other = known_prism(box)
            depth = motion_safety.held_depths(held_prism(block), poses, other)
            if motion_safety.held_intrusion(depth, motion_safety.HELD_CONTACT_TOL_MM - PRECHECK_MARGIN_MM) is not None:
                i = int(np.argmax(depth))
                c = poses[i, :3, 3]
                return (f"the {block.name} would go {depth[i]:.1f} mm into {other.name}, with its centre at "
                        f"({c[0]:.1f}, {c[1]:.1f}, {c[2]:.1f}) mm")
    return None


def check_whole_plan(plan: planning.Plan, arm: GuardedArm, opening_mm: float,
                     held: Sequence[motion_safety.HeldBlock] = (), grasped: motion_safety.HeldBlock | None = None,
                     known: Sequence[KnownBox] = (), what: str = "plan",
                     gripper: GripperGeometry = GRIPPER) -> None:
    """Raise MotionRefused naming the step when any command `arm` would send for `plan` would be refused by an arm
    or carry the held block into a known block (module notes); return None when the whole plan passes. Nothing is
    sent."""
    try:
        pairs = plan_segments(plan, arm, opening_mm, held, grasped, gripper)
        if not pairs:
            return
        segments = [seg for seg, _ in pairs]
        start_cmd = arm.sag.command(np.asarray(plan.start, float), arm.robot)
        sim_floor = replace(motion_safety.SIM_CLEARANCE,
                            contact_mm=motion_safety.SIM_CLEARANCE.contact_mm + PRECHECK_MARGIN_MM)
        motion_safety.check_plan(start_cmd, segments, arm.robot, motion_safety.REAL_CLEARANCE, gripper)
        motion_safety.check_plan(start_cmd, segments, arm.robot, sim_floor, gripper,
                                 physical=lambda Q: arm.sag.physical(Q, arm.robot))
    except MotionRefused as e:
        raise MotionRefused(f"{what} refused before moving: {e}") from None
    q = np.asarray(plan.start, float)
    for seg, q_next in pairs:
        hit = _held_hits(q, q_next, seg.held, known)
        if hit:
            raise MotionRefused(f"{what} refused before moving: {seg.label}: {hit} (nothing was sent to the arm)")
        q = q_next

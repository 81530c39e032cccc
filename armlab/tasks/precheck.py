"""A pick or place plan checked whole before its first command: the plan -> armlab.motion_safety segments with the
pads' opening and the held block along it, under the task layer's sag model, plus the held block against the blocks
the task layer knows (its detections).

What the arms refuse mid-plan, checked here first (MotionRefused names the step, before anything is sent):
- every command GuardedArm would send (sag.command of the planned joints) by motion_safety.check_plan: joint limits,
  time profile, velocity limits; the board clearance on the commanded angles with the real arm's link margin
  (REAL_CLEARANCE), and on the angles the task layer predicts the links take (sag.physical of the commands) with the
  simulator's floors (SIM_CLEARANCE), the contact floor (pads, held block) PRECHECK_MARGIN_MM stricter to cover the
  sag model's residual;
- the held block against the known blocks along every move it is carried: its surface sampled on a grid, each known
  block an upright box (a detection: its top-face centre, yaw and edge; an Obstacle from an earlier place: its
  cylinder), and their top edges sampled against the held cube, under the arms' rule (motion_safety.held_intrusion)
  with PRECHECK_MARGIN_MM less allowance (none: the simulator allows 0.5 mm, the margin covers detection error).
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
from armlab.transforms import homogeneous, wrap_quarter

from .guard import GuardedArm

__all__ = ["PRECHECK_MARGIN_MM", "KnownBox", "known_boxes", "held_pose_at_grasp", "plan_segments", "check_whole_plan"]

PRECHECK_MARGIN_MM = 0.5        # the contact floor and the held block's clearance are this much stricter than the sim
_GRID = 7                       # samples per cube edge on each face of the held block


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
    T_tool = kinematics.fk(np.asarray(q_grasp, float))
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


def _cube_surface(edge: float) -> np.ndarray:
    """Points (6 g^2, 3) on the surface of a cube of `edge` mm centred at the origin (a g x g grid on each face)."""
    g = np.linspace(-0.5, 0.5, _GRID) * edge
    a, b = (m.ravel() for m in np.meshgrid(g, g))
    h = np.full_like(a, edge / 2)
    faces = [np.column_stack(v) for v in ((h, a, b), (-h, a, b), (a, h, b), (a, -h, b), (a, b, h), (a, b, -h))]
    return np.concatenate(faces)


def _box_edges(box: KnownBox) -> np.ndarray:
    """Points (m, 3) on a known box's top edges and its vertical edges (world mm)."""
    g = np.linspace(-1.0, 1.0, 2 * _GRID + 1) * box.half
    yaw = 0.0 if box.yaw is None else box.yaw
    c, s = np.cos(yaw), np.sin(yaw)
    local = [np.column_stack([g, np.full_like(g, sy)]) for sy in (-box.half, box.half)]
    local += [np.column_stack([np.full_like(g, sx), g]) for sx in (-box.half, box.half)]
    xy = np.concatenate(local)
    top = np.column_stack([box.x + c * xy[:, 0] - s * xy[:, 1], box.y + s * xy[:, 0] + c * xy[:, 1],
                           np.full(len(xy), box.top)])
    corners = top[[0, 2 * _GRID, 2 * _GRID + 1, 4 * _GRID + 1]]
    zs = np.linspace(0.0, box.top, 2 * _GRID + 1)
    vertical = np.concatenate([np.column_stack([np.repeat(p[None, :2], len(zs), 0), zs]) for p in corners])
    return np.concatenate([top, vertical])


def _inside_box(points: np.ndarray, box: KnownBox) -> np.ndarray:
    """Depth (...,) mm of world points inside a known box (<= 0 outside): the least distance to its surface."""
    d = points[..., :2] - [box.x, box.y]
    up = box.top - points[..., 2]
    if box.yaw is None:
        side = box.half - np.linalg.norm(d, axis=-1)
    else:
        c, s = np.cos(box.yaw), np.sin(box.yaw)
        u, v = c * d[..., 0] + s * d[..., 1], -s * d[..., 0] + c * d[..., 1]
        side = box.half - np.maximum(np.abs(u), np.abs(v))
    return np.minimum(np.minimum(side, up), points[..., 2])


def _held_hits(q0, q1, held: Sequence[motion_safety.HeldBlock], boxes: Sequence[KnownBox]) -> str | None:
    """Why carrying `held` along the straight planned joint path q0 -> q1 would push it into a known box, or None."""
    if not held or not boxes:
        return None
    s = motion_safety.held_path_fractions(q0, q1)
    T = kinematics.fk(q0 + s[:, None] * (q1 - q0), check_limits=False)                 # (n, 4, 4)
    for block in held:
        T_b = T @ np.asarray(block.T_tool_block, float)                                 # (n, 4, 4) cube poses
        centres = T_b[:, :3, 3]
        surface = np.einsum("nij,kj->nki", T_b[:, :3, :3], _cube_surface(block.edge_mm)) + centres[:, None]
        for box in boxes:
            near = np.hypot(centres[:, 0] - box.x, centres[:, 1] - box.y) < (block.edge_mm + 2 * box.half) * 0.75 + 1
            if not near.any() or centres[near, 2].min() - block.edge_mm > box.top:
                continue
            inside = _inside_box(surface[near], box).max(axis=1)                       # held surface into the box
            edges = _box_edges(box)
            local = np.einsum("nji,nkj->nki", T_b[near, :3, :3], edges[None] - centres[near, None])
            depth = np.full(len(s), -np.inf)
            depth[near] = np.maximum(inside, (block.edge_mm / 2 - np.abs(local).max(axis=2)).max(axis=1))
            # the arms' rule (motion_safety.held_intrusion); PRECHECK_MARGIN_MM of its allowance covers detection error
            if motion_safety.held_intrusion(depth, motion_safety.HELD_CONTACT_TOL_MM - PRECHECK_MARGIN_MM) is not None:
                i = int(np.argmax(depth))
                c = centres[i]
                return (f"the {block.name} would go {depth[i]:.1f} mm into the known block at ({box.x:.1f}, "
                        f"{box.y:.1f}) mm (top {box.top:.1f} mm), with its centre at ({c[0]:.1f}, {c[1]:.1f}, "
                        f"{c[2]:.1f}) mm")
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

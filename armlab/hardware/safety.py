"""The real arm's safety layer: armlab.motion_safety's rules (the same the simulator obeys) with the real arm's
floors, checked on the measured joints and the measured finger opening before anything is sent.

The Interbotix driver moves every joint with the same time-based trapezoidal profile, so the arm follows the
straight joint-space line that motion_safety samples. The real arm checks COMMANDED angles: its links keep
board_margin_mm (default DEFAULT_BOARD_MARGIN_MM = motion_safety.REAL_LINK_MARGIN_MM) above the board to cover the
sag the driver does not model; its finger pads, like the simulator's, may press motion_safety.BOARD_CONTACT_TOL_MM
into it. What the arm holds (RealArm.held_blocks, set by the task layer's executor at the grasp) is checked on
every move by the same held-block routine as the executor's whole-plan pre-check (motion_safety.held_depths).
Units: rad, s, mm; heights are world z (the board surface is z = 0).
"""

from __future__ import annotations

import numpy as np

from armlab import motion_safety
from armlab.gripper_geometry import GRIPPER, GripperGeometry
from armlab.robot import RobotModel

__all__ = ["DEFAULT_BOARD_MARGIN_MM", "MAX_MOVING_TIME_S", "clearance", "pad_opening_mm", "board_collision",
           "check_move"]

DEFAULT_BOARD_MARGIN_MM = motion_safety.REAL_LINK_MARGIN_MM
MAX_MOVING_TIME_S = motion_safety.MAX_MOVING_TIME_S


def clearance(board_margin_mm: float = DEFAULT_BOARD_MARGIN_MM) -> motion_safety.BoardClearance:
    """The real arm's floors: links at board_margin_mm, pads at the contact tolerance (motion_safety.REAL_CLEARANCE
    with another link margin)."""
    return motion_safety.BoardClearance(links_mm=float(board_margin_mm))


def pad_opening_mm(finger_mm: float, gripper: GripperGeometry = GRIPPER) -> float:
    """The gap between the pads (mm) for the measured left finger position (mm from the gripper centre, the
    driver's 'left_finger' joint), within the gripper's travel."""
    return float(np.clip(2 * (finger_mm - gripper.pad_thickness_mm), gripper.min_opening_mm, gripper.max_opening_mm))


def board_collision(q_from, q_to, margin_mm: float = DEFAULT_BOARD_MARGIN_MM, robot: RobotModel | None = None,
                    opening_mm: float | None = None) -> str | None:
    """Why the straight joint path q_from -> q_to (5,) rad takes a part below its floor (links: margin_mm; pads,
    when opening_mm is given: the contact tolerance), in words; None when it is clear."""
    return motion_safety.board_intrusion(q_from, q_to, clearance(margin_mm), robot, GRIPPER, opening_mm)


def check_move(q_from, q_to, moving_time: float | None = None, accel_time: float | None = None,
               robot: RobotModel | None = None, board_margin_mm: float = DEFAULT_BOARD_MARGIN_MM,
               opening_mm: float | None = None) -> tuple[float, float]:
    """Validate a move from the measured q_from to q_to (5,) rad with the pads opening_mm apart (None: pads not
    checked); return the (moving_time, accel_time) s to send. Raises MotionRefused naming the problem (see
    armlab.motion_safety)."""
    return motion_safety.check_move(q_from, q_to, moving_time, accel_time, robot, clearance(board_margin_mm),
                                    GRIPPER, opening_mm)

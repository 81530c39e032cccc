"""Motion planning: time scaling, joint-space and Cartesian trajectories, grasp choice, pick and place plans.

Pure and kinematic: nothing here talks to a station; `execute(plan, arm)` runs a plan on any armlab Arm.
Units: mm, rad, s; world (board) frame. Modules: timing (time scaling), trajectory (joint moves, Cartesian lines),
descent (how the kit's plans come down to a block: the seam with exercise grab.move_path), grasp (wrist roll and pitch
for a block), straightness (how straight a plan comes down), transit (obstacles and clearance), plan (Plan, execute,
sampling, plots), pickplace (pick, place and camera-clear plans).
"""

from .descent import approach_reachable, descend
from .grasp import (
    LIMIT_MARGIN_RAD,
    MAX_CLOSING_TILT_RAD,
    PAD_CLEARANCE_MM,
    GraspPose,
    choose_grasp,
    face_misalignment,
    face_roll,
    inner_limits,
    level_pitch_roll,
    pad_clearance,
    steepest_pitch_inside,
    tilted_roll,
)
from .pickplace import (
    CAMERA_CLEAR_POSE,
    default_grasp_depth,
    grasp_height,
    place_tool_height,
    plan_camera_clear,
    plan_pick,
    plan_pick_place,
    plan_place,
    tilted_release_lift,
)
from .plan import (
    GRIPPER_TIME_S,
    ExecutionResult,
    GripperStep,
    MoveStep,
    Plan,
    PlanSample,
    execute,
    joint_moves,
    plot_plan,
    sample_plan,
)
from .straightness import STRAIGHT_TOLERANCE_MM, approach_deviation
from .timing import SCALINGS, moving_time, time_scaling
from .trajectory import (
    CartesianSegment,
    JointChord,
    JointTrajectory,
    PiecewiseTrajectory,
    ToolSegment,
    Trajectory,
    Waypoint,
    cartesian_line,
    joint_chord,
    joint_move,
    reverse,
)
from .transit import DEFAULT_CLEARANCE_MM, Clearance, Obstacle, as_obstacles, transit_clearance

__all__ = [
    "LIMIT_MARGIN_RAD", "MAX_CLOSING_TILT_RAD", "GraspPose", "choose_grasp", "face_misalignment", "face_roll",
    "tilted_roll", "PAD_CLEARANCE_MM", "pad_clearance", "inner_limits", "steepest_pitch_inside",
    "level_pitch_roll",
    "CAMERA_CLEAR_POSE", "default_grasp_depth", "grasp_height", "place_tool_height", "plan_camera_clear", "plan_pick",
    "plan_pick_place",
    "plan_place", "tilted_release_lift",
    "GRIPPER_TIME_S", "ExecutionResult", "GripperStep", "MoveStep", "Plan", "PlanSample", "execute", "plot_plan",
    "sample_plan", "joint_moves",
    "SCALINGS", "moving_time", "time_scaling",
    "CartesianSegment", "JointChord", "JointTrajectory", "PiecewiseTrajectory", "ToolSegment", "Trajectory", "Waypoint",
    "cartesian_line", "joint_chord", "joint_move", "reverse", "descend", "approach_reachable",
    "STRAIGHT_TOLERANCE_MM", "approach_deviation",
    "DEFAULT_CLEARANCE_MM", "Clearance", "Obstacle", "as_obstacles", "transit_clearance",
]

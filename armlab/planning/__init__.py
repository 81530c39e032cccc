"""Motion planning: time scaling, joint-space and Cartesian trajectories, grasp choice, pick and place plans.

Pure and kinematic: nothing here talks to a station; `execute(plan, arm)` runs a plan on any armlab Arm.
Units: mm, rad, s; world (board) frame. Modules: timing (time scaling), trajectory (joint moves, Cartesian lines),
grasp (wrist roll and pitch for a block), transit (obstacles and clearance), plan (Plan, execute, sampling, plots),
pickplace (pick, place and camera-clear plans).
"""

from .grasp import (
    LIMIT_MARGIN_RAD,
    MAX_CLOSING_TILT_RAD,
    PAD_CLEARANCE_MM,
    GraspPose,
    choose_grasp,
    face_misalignment,
    face_roll,
    inner_limits,
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
from .timing import SCALINGS, moving_time, time_scaling
from .trajectory import (
    CartesianSegment,
    JointTrajectory,
    PiecewiseTrajectory,
    Trajectory,
    Waypoint,
    cartesian_line,
    joint_move,
    reverse,
)
from .transit import DEFAULT_CLEARANCE_MM, Clearance, Obstacle, as_obstacles, transit_clearance

__all__ = [
    "LIMIT_MARGIN_RAD", "MAX_CLOSING_TILT_RAD", "GraspPose", "choose_grasp", "face_misalignment", "face_roll",
    "tilted_roll", "PAD_CLEARANCE_MM", "pad_clearance", "inner_limits", "steepest_pitch_inside",
    "CAMERA_CLEAR_POSE", "default_grasp_depth", "grasp_height", "place_tool_height", "plan_camera_clear", "plan_pick",
    "plan_pick_place",
    "plan_place", "tilted_release_lift",
    "GRIPPER_TIME_S", "ExecutionResult", "GripperStep", "MoveStep", "Plan", "PlanSample", "execute", "plot_plan",
    "sample_plan", "joint_moves",
    "SCALINGS", "moving_time", "time_scaling",
    "CartesianSegment", "JointTrajectory", "PiecewiseTrajectory", "Trajectory", "Waypoint", "cartesian_line",
    "joint_move", "reverse",
    "DEFAULT_CLEARANCE_MM", "Clearance", "Obstacle", "as_obstacles", "transit_clearance",
]

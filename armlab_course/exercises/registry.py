"""The course's one declaration per exercise, and the typed exception a blank exercise raises.

A leaf module of the course: of armlab it imports only armlab.slots (the engine's SlotNotWritten, which a blank
exercise's ExerciseNotWritten is). The library never imports the course; it names its slots by the exercise's id.

An exercise is one of three kinds:
- "code": code a student writes between `# BEGIN SOLUTION <id>` and `# END SOLUTION` lines, either in a notebook
  (`where` is the notebook's source) or in the package (`where` is the source file; its function's docstring names
  the notebook that teaches it), checked on hidden inputs;
- "open": the same markers, graded by outcome on hidden seeds or held-out frames (a strategy's score, a detector's
  accuracy);
- "written": an answer in a markdown cell between `<!-- BEGIN ANSWER <id> -->` and `<!-- END ANSWER -->`, tied to a
  figure, collected for the instructor to grade by hand.
`hidden` names the module of armlab_course.grading.hidden holding the exercise's hidden checks (instructor only).
"""

from __future__ import annotations

from dataclasses import dataclass, field

from armlab.slots import SlotNotWritten

__all__ = ["Exercise", "EXERCISES", "KINDS", "NOTEBOOKS", "ExerciseNotWritten", "exercise", "notebook_of",
           "of_notebook"]

KINDS = ("code", "open", "written")


@dataclass(frozen=True)
class Exercise:
    """id: stable (e.g. "fk.dh_table"); title: what to write; points; notebook: the notebook that teaches it (its
    file stem); where: the file holding the region(s) (a notebook source "notebooks/src/NN_name.py" or a package
    file "armlab/..."); functions: the functions (or variables) the regions complete (for a written answer: the
    figure it is about); kind: "code", "open" or "written"; hidden: the module of armlab_course.grading.hidden with its
    hidden checks ('' for a written answer)."""

    id: str
    title: str
    points: int
    notebook: str
    where: str
    functions: tuple[str, ...]
    kind: str = "code"
    hidden: str = field(default="")

    def __post_init__(self):
        if self.kind not in KINDS:
            raise ValueError(f"exercise {self.id}: kind must be one of {KINDS}, got {self.kind!r}")
        if self.points <= 0:
            raise ValueError(f"exercise {self.id}: points must be positive, got {self.points}")
        if not self.hidden and self.kind != "written":
            object.__setattr__(self, "hidden", self.id.replace(".", "_"))

    @property
    def in_package(self) -> bool:
        return self.where.startswith("armlab/")

    @property
    def notebook_number(self) -> str:
        return self.notebook[:2]

    def label(self) -> str:
        """How a note names the exercise: 'exercise <id> (notebook NN)'."""
        return f"exercise {self.id} (notebook {self.notebook_number})"

    def message(self) -> str:
        """What a blank stub says: the exercise, the notebook that teaches it and what to write where."""
        what = " and ".join(self.functions) if len(self.functions) < 3 else \
            ", ".join(self.functions[:-1]) + " and " + self.functions[-1]
        if self.kind == "written":
            return f"{self.label()}: answer the question about {what}"
        place = f" in {self.where}" if self.in_package else ""
        return f"{self.label()}: write {what}{place}"


class ExerciseNotWritten(SlotNotWritten):
    """Raised by a blank exercise's stub in a notebook: the engine's SlotNotWritten (armlab.slots) for the exercise's
    id (`exercise_id`, the same as `slot_id`), labelled with its notebook; the message says what to write where. The
    kit's stand-ins (armlab.slots.standin, armlab_course.exercises.fallback) answer for exactly this error of exactly
    their exercise. (A package file's stub raises SlotNotWritten itself, with the same message and label: the
    released engine imports no course code.)"""

    def __init__(self, exercise_id: str):
        e = exercise(exercise_id)
        super().__init__(e.id, e.message(), e.label())

    @property
    def exercise_id(self) -> str:
        return self.slot_id

    def __reduce__(self):
        return type(self), (self.exercise_id,)


NOTEBOOKS = ("00_getting_started", "01_camera_calibration", "01_going_further", "02_forward_kinematics",
             "03_inverse_kinematics", "04_block_detection", "05_click_to_grab", "06_teach_and_repeat",
             "07_autonomous_tasks", "08_control_station")
_NB = {n[:2]: n for n in NOTEBOOKS if n != "01_going_further"}


def _src(number: str) -> str:
    return f"notebooks/src/{_NB[number]}.py"


# -- notebook 01: the camera ------------------------------------------------------------------------------------
PINHOLE = Exercise("calib.pinhole", "the pinhole model both ways: project world points, back-project a pixel with its "
                   "depth", 8, _NB["01"], _src("01"), ("project_pinhole", "pixel_to_world_pinhole"))
ZHANG = Exercise("calib.zhang", "the intrinsics K in closed form from the checkerboard views' homographies "
                 "(Zhang's method)", 8, _NB["01"], _src("01"), ("intrinsics_from_homographies",))
TAG_HOMOGRAPHY = Exercise("calib.tag_homography", "the homography by the normalised direct linear transform (DLT)",
                          6, _NB["01"], "armlab/calibration/homography.py", ("dlt_homography",))
TAG_EXTRINSICS = Exercise("calib.tag_extrinsics", "the camera's pose from the AprilTag corners (planar pose from a "
                          "homography)", 8, _NB["01"], "armlab/calibration/extrinsics.py", ("pose_from_corners",))
DEPTH_PLANE = Exercise("calib.depth_plane", "fit the depth camera's planar bias", 4, _NB["01"],
                       "armlab/calibration/depth.py", ("fit_depth_correction",))
Q_REPROJECTION = Exercise("calib.q_reprojection", "why the board-to-image error grows toward the corners", 3,
                          _NB["01"], _src("01"), ("the homography error figure",), kind="written")
Q_VIEWS = Exercise("calib.q_views", "what adding views does to the closed form's focal length and principal point",
                   3, _NB["01"], _src("01"), ("the views-against-error figure",), kind="written")
# -- notebook 02: forward kinematics ----------------------------------------------------------------------------
DH_LINK = Exercise("fk.dh_link_transform", "one DH link transform, batched (the kit's)", 4, _NB["02"],
                   "armlab/kinematics.py", ("dh_link_transform",))
DH_TABLE = Exercise("fk.dh_table", "the RX200's DH frame assignment and table, from its geometry", 8, _NB["02"],
                    _src("02"), ("dh_table",))
EULER = Exercise("fk.euler", "ZYZ Euler angles from a pose (the report's get_euler_angles_from_T)", 5, _NB["02"],
                 _src("02"), ("euler_angles_from_T",))
Q_FRAMES = Exercise("fk.q_frames", "what frame 4 adds and why x2 runs along the hypotenuse", 3, _NB["02"],
                    _src("02"), ("the DH frames figure",), kind="written")
Q_TABLE_ERROR = Exercise("fk.q_table_error", "predict, then read the map of Table I's tool-point error over the board",
                         3, _NB["02"], _src("02"), ("the Table I error map",), kind="written")
# -- notebook 03: inverse kinematics ----------------------------------------------------------------------------
IK_BRANCHES = Exercise("ik.candidates", "the geometric IK from the triangle figure: the planar two-link problem and "
                       "the wrist pitch, every branch", 14, _NB["03"], "armlab/kinematics.py", ("_branch_joints",))
Q_BRANCHES = Exercise("ik.q_branches", "which branches the arm can use, from the branches figure", 3, _NB["03"],
                      _src("03"), ("the IK branches figure",), kind="written")
IK_NUMERICAL = Exercise("ik.numerical", "the geometric Jacobian from the link frames, the pose error and a damped "
                        "least squares IK", 8, _NB["03"], _src("03"),
                        ("tool_jacobian", "pose_error", "solve_ik_dls"))
Q_DAMPING = Exercise("ik.q_damping", "predict, then explain what the damping does beyond and inside the reach", 3,
                     _NB["03"], _src("03"), ("the damping figure",), kind="written")
# -- notebook 04: block detection -------------------------------------------------------------------------------
SEGMENT = Exercise("detect.segment", "the report's segmentation: blur, HSV boxes tuned on training frames, erosion "
                   "and dilation", 8, _NB["04"], _src("04"), ("segment_colours", "tuned_hsv_ranges"), kind="open")
FACE = Exercise("detect.face", "a face's centre (moments), yaw (from its outline) and size class from its mask", 6,
                _NB["04"], _src("04"), ("face_geometry",))
CLASSIFY = Exercise("detect.classify", "nearest colour class with per-class spreads", 5, _NB["04"],
                    "armlab/detection/color.py", ("ColorModel.classify",))
CONFUSION_QUESTION = Exercise("detect.confusion_question", "why the report's HSV table misses rendered faces", 2,
                              _NB["04"], _src("04"), ("the confusion matrices",), kind="written")
STACKS = Exercise("detect.stacks", "a stack's top height, levels and top-face centre from the depth image", 6,
                  _NB["04"], _src("04"), ("stack_from_depth",))
Q_STACKS = Exercise("detect.q_stacks", "predict, then explain how the mean over a stack's mask reads its top", 2,
                   _NB["04"], _src("04"), ("the stacks figure",), kind="written")
# -- notebook 05: click to grab ---------------------------------------------------------------------------------
CLICK_TARGET = Exercise("grab.click_target", "which detected block a click hit: its turned top face under the click, "
                        "the surface the depth saw", 5, _NB["05"], _src("05"), ("click_target",))
MOVE_PATH = Exercise("grab.move_path", "the report's move_path: the grasp and release motion as a plan", 10,
                     _NB["05"], "armlab/tasks/move_path.py", ("move_path",), kind="open")
CLICK_SEQUENCE = Exercise("grab.sequence", "click to grab, click to drop: which block a click means, where the held "
                          "block goes, what to believe after each move", 8, _NB["05"], _src("05"), ("ClickSequence",),
                          kind="open")
SAG_QUESTION = Exercise("grab.sag_question", "what the sag figure says about the report's flat offset", 2, _NB["05"],
                        _src("05"), ("the sag figure",), kind="written")
# -- notebook 06: teach and repeat ------------------------------------------------------------------------------
TEACH_REPLAY = Exercise("teach.replay", "teach by hand, then a time-scaled replay within every limit, as a plan", 10,
                        _NB["06"], _src("06"), ("teach_program", "scaled_durations", "scaled_plan"))
REPLAY_QUESTION = Exercise("teach.replay_question", "taught replay against move_path, from the joint-angle figure", 2,
                           _NB["06"], _src("06"), ("the joint-angle figure",), kind="written")
# -- notebook 07: autonomous tasks ------------------------------------------------------------------------------
SORT_STACK = Exercise("events.sort_stack", "a sort 'n stack strategy for every level from what the robot sees",
                      12, _NB["07"], _src("07"), ("SortStackStrategy",), kind="open")
LINE_UP = Exercise("events.line_up", "a line 'em up strategy for every level: the lines' layout, clearing the way, "
                   "unstacking", 12, _NB["07"], _src("07"), ("LineUpStrategy",), kind="open")
SKY = Exercise("events.sky", "a to-the-sky strategy: the tower's spot, the carry over its top and when to stop", 8,
               _NB["07"], _src("07"), ("SkyStrategy",), kind="open")
TOWER_QUESTION = Exercise("events.tower_question", "the tower's points and what stops it", 2, _NB["07"], _src("07"),
                          ("the tower figure",), kind="written")
# -- notebook 08: the control station ---------------------------------------------------------------------------
COMMAND_TRANSITION = Exercise("station.transition", "one transition of the station's state machine: a command from "
                              "idle and back", 6, _NB["08"], _src("08"), ("run_command",))
STATION_MACHINE = Exercise("station.machine", "the station's whole state machine over the kit's port: the buttons, "
                           "the E-STOP and reset, teach and repeat", 12, _NB["08"], _src("08"), ("StationMachine",),
                           kind="open")

EXERCISES: tuple[Exercise, ...] = tuple(v for v in dict(globals()).values() if isinstance(v, Exercise))

_BY_ID = {e.id: e for e in EXERCISES}
if len(_BY_ID) != len(EXERCISES):
    raise ValueError("two exercises share an id")


def exercise(exercise_id: str) -> Exercise:
    """The registered exercise with this id (KeyError naming the known ids otherwise)."""
    try:
        return _BY_ID[exercise_id]
    except KeyError:
        raise KeyError(f"no exercise {exercise_id!r}; registered: {', '.join(sorted(_BY_ID))}") from None


def notebook_of(exercise_id: str) -> str:
    """The notebook (file stem) that teaches the exercise."""
    return exercise(exercise_id).notebook


def of_notebook(notebook: str) -> tuple[Exercise, ...]:
    """The exercises a notebook (file stem, or its two-digit number) teaches, in the registry's order."""
    return tuple(e for e in EXERCISES if notebook in (e.notebook, e.notebook_number))

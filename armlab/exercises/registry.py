"""The exercise registry: one declaration per exercise, read by the markers, the student release, the notebooks'
messages, `python -m armlab exercises` and the grader.

An exercise is code a student writes, between `# BEGIN SOLUTION <id>` and `# END SOLUTION` lines, either in a
notebook (`where` is the notebook) or in the package (`where` is the source file; its function's docstring names the
notebook that teaches it). `checks` are the public check cells that grade it: notebook code cells carrying a
`# CHECK <id>` comment line. Points add up to the course's total for these labs.
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["Exercise", "EXERCISES", "exercise", "notebook_of"]


@dataclass(frozen=True)
class Exercise:
    """id: stable (e.g. "fk.dh_transform"); title: what to write; points; notebook: the notebook that teaches it
    (its file stem); where: the file holding the region(s) (a notebook source "notebooks/src/NN_name.py" or a package
    file "armlab/..."); functions: the functions (or variables) the regions complete."""

    id: str
    title: str
    points: int
    notebook: str
    where: str
    functions: tuple[str, ...]

    @property
    def in_package(self) -> bool:
        return self.where.startswith("armlab/")

    @property
    def notebook_number(self) -> str:
        return self.notebook[:2]

    def message(self) -> str:
        """What a blank stub says: the exercise, the notebook that teaches it and what to write where."""
        what = " and ".join(self.functions) if len(self.functions) < 3 else \
            ", ".join(self.functions[:-1]) + " and " + self.functions[-1]
        place = f" in {self.where}" if self.in_package else ""
        return f"exercise {self.id} (notebook {self.notebook_number}): write {what}{place}"


_NB = {n[:2]: n for n in ("00_getting_started", "01_camera_calibration", "02_forward_kinematics",
                          "03_inverse_kinematics", "04_block_detection", "05_click_to_grab", "06_teach_and_repeat",
                          "07_autonomous_tasks")}


def _src(number: str) -> str:
    return f"notebooks/src/{_NB[number]}.py"


EXERCISES: tuple[Exercise, ...] = (
    Exercise("calib.project_pinhole", "project world points through the pinhole model", 4, _NB["01"], _src("01"),
             ("project_pinhole",)),
    Exercise("calib.tag_extrinsics", "the camera's pose from the AprilTag corners (planar pose from a homography)", 8,
             _NB["01"],
             "armlab/calibration/extrinsics.py", ("pose_from_corners",)),
    Exercise("calib.tag_homography", "the homography by the normalised direct linear transform (DLT)", 6,
             _NB["01"], "armlab/calibration/homography.py", ("dlt_homography",)),
    Exercise("calib.pixel_to_world_pinhole", "back-project a pixel with its depth into the world", 4, _NB["01"],
             _src("01"), ("pixel_to_world_pinhole",)),
    Exercise("calib.depth_plane", "fit the depth camera's planar bias", 4, _NB["01"],
             "armlab/calibration/depth.py", ("fit_depth_correction",)),
    Exercise("fk.dh_transform", "one DH link transform", 4, _NB["02"], _src("02"), ("dh_transform",)),
    Exercise("fk.fk_from_table", "forward kinematics by chaining the DH table", 4, _NB["02"], _src("02"),
             ("fk_from_table",)),
    Exercise("fk.dh_link_transform", "the kit's batched DH link transform", 3, _NB["02"], "armlab/kinematics.py",
             ("dh_link_transform",)),
    Exercise("ik.planar_ik", "the planar two-link IK with both elbow branches", 8, _NB["03"], _src("03"),
             ("planar_ik",)),
    Exercise("ik.candidates", "the kit's closed-form IK: all four branches", 10, _NB["03"], "armlab/kinematics.py",
             ("_branch_joints",)),
    Exercise("detect.segment", "the report's segmentation: blur, HSV boxes tuned on training frames, erosion and "
             "dilation", 8, _NB["04"], _src("04"), ("segment_colours", "tuned_hsv_ranges")),
    Exercise("detect.face", "a face's centre (moments), yaw (its outline, wrapped) and size class from its mask", 6,
             _NB["04"], _src("04"), ("face_geometry",)),
    Exercise("detect.classify", "nearest colour class with per-class spreads", 5, _NB["04"],
             "armlab/detection/color.py", ("ColorModel.classify",)),
    Exercise("grab.move_path", "the report's move_path: hover, descend, grasp or release, lift", 10, _NB["05"],
             "armlab/tasks/move_path.py", ("move_path",)),
    Exercise("teach.record", "the teaching loop: pose by hand, record a waypoint", 5, _NB["06"], _src("06"),
             ("teach_program",)),
    Exercise("teach.time_scaled", "a time-scaled replay: segment times within every limit", 5, _NB["06"],
             _src("06"), ("scaled_durations",)),
    Exercise("events.sort_stack", "a sort 'n stack strategy for levels 2 and 3 from what the robot sees", 12,
             _NB["07"], _src("07"), ("SortStackStrategy",)),
)

_BY_ID = {e.id: e for e in EXERCISES}


def exercise(exercise_id: str) -> Exercise:
    """The registered exercise with this id (KeyError naming the known ids otherwise)."""
    try:
        return _BY_ID[exercise_id]
    except KeyError:
        raise KeyError(f"no exercise {exercise_id!r}; registered: {', '.join(sorted(_BY_ID))}") from None


def notebook_of(exercise_id: str) -> str:
    """The notebook (file stem) that teaches the exercise."""
    return exercise(exercise_id).notebook

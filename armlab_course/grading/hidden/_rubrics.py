"""The point rubric of every written question (instructor only, like the rest of armlab_course.grading.hidden: not in
the student release, where a rubric would tell the answer).

Each criterion is something the marker can find in the answer, with its points; a question's criteria add up to its
points in the registry. The model answers are in the instructor's notebook sources, between the answer markers, each
checked against the figure the question follows (armlab_course.grading.hand reads them from there).
"""

from __future__ import annotations

from dataclasses import dataclass

from armlab_course.exercises.registry import EXERCISES, exercise

__all__ = ["Criterion", "RUBRICS", "GIVEAWAYS", "FIGURE_FACTS", "rubric_of"]


@dataclass(frozen=True)
class Criterion:
    """points: what the criterion is worth (whole or half points); text: what the answer must say or show."""

    points: float
    text: str


def _c(*pairs) -> tuple[Criterion, ...]:
    return tuple(Criterion(float(p), t) for p, t in pairs)


RUBRICS: dict[str, tuple[Criterion, ...]] = {
    "calib.q_reprojection": _c(
        (0.5, "the prediction was written before the figure (a pattern over the board and a reason)"),
        (1, "names lens distortion (radial, k1 r^2 ...) as what a homography, a projective map, cannot represent"),
        (1, "the distortion's displacement grows with the distance from the image centre, so the board's corners "
            "and borders (far from the centre in the image) are off most"),
        (0.5, "zero at the tags: the homography is fitted through the four tag centres exactly (4 pairs fix its 8 "
              "parameters)")),
    "calib.q_views": _c(
        (1, "reads the figure: the focal error falls from 27 % (3 views) to about 1.6 % (5) and stays at 1-2 %; the "
            "principal point error falls from 47 px to 1.3 px at 6 views, then rises to 6-10 px and stays there"),
        (1, "explains the floor: the closed form ignores the lens distortion, so each homography is biased; more "
            "views average noise, not a bias"),
        (1, "explains why the principal point moves: it is the parameter the views determine least well (it trades "
            "against the tilt of the views and the distortion); views added later (tilted, near the border) pull it "
            "off; the good value at 6 views is luck, not convergence")),
    "fk.q_frames": _c(
        (1.5, "(a) frame 4 adds no length but turns z onto the wrist_rotate axis (alpha4 = -90 deg), so the last "
              "joint can turn about the approach direction"),
        (1.5, "(b) the L-shaped upper arm: along the 200 mm segment x2 would not reach the elbow axis and the 50 mm "
              "offset has no DH parameter; along the hypotenuse one length a2 and the tilt beta in the theta offsets "
              "place the elbow")),
    "fk.q_table_error": _c(
        (0.5, "the prediction (before the figure) is stated: a pattern over the board and a size"),
        (1, "reads the map: the error is nearly uniform over the board (about 5 mm for 152.575 mm, 16.5 mm for "
            "174.15 mm), varying by about 0.5 mm"),
        (1, "explains it: a top-down grasp holds the tool axis vertical, so a wrong wrist-to-tool length is a height "
            "error of the same size everywhere; the shorter shoulder height and hypotenuse add a little"),
        (0.5, "consequence: a few mm is half the clearance of a block in the gripper; use the manufacturer's lengths "
              "and put measured corrections (sag) on top")),
    "ik.q_branches": _c(
        (1, "(a) the flipped elbow-down branch breaks a limit, and it is the wrist_angle (about -116 deg against its "
            "-100 deg limit) that stops it, read from the figure"),
        (1, "(b) a physical reason for facing elbow up: the elbow stays high above the board and the blocks, least "
            "waist motion from home, no swing over the base"),
        (1, "(b) where only the flipped waist reaches: targets behind the base / near the base axis where facing "
            "would need the shoulder to lean past its limit (section 4's count)")),
    "ik.q_damping": _c(
        (0.5, "the prediction (before the figure) says what each damping will do beyond the reach"),
        (1, "beyond the reach: small damping (0.1, 2 mm/rad) oscillates between about 10.2 and 11 mm, never "
            "settling; large damping (30 mm/rad) settles at the 10 mm the target is out of reach"),
        (1, "inside the reach: small damping converges in about 10 iterations (orders of magnitude per step), large "
            "damping only linearly, in 36"),
        (0.5, "the trade-off, tied to the method: damping limits the step near a singularity (the stretched arm) at "
              "the price of slow convergence; choose it small, or adapt it")),
    "detect.confusion_question": _c(
        (0.5, "the prediction (before the figure) names which colours the table will miss and why"),
        (1, "per missed colour the bound that rejects it, from the medians: red's hue (near 0, the box 140-180); "
            "green, blue and violet the V floor (violet's hue also just past its box)"),
        (0.5, "white balance scales the channels to make the board grey: it changes neither brightness much nor red's "
              "hue, so the floors and red's box still fail; in the lab: re-sample each colour's HSV over the whole "
              "board under the competition light and set bounds a margin outside the spread")),
    "detect.q_stacks": _c(
        (0.5, "the prediction (before the figure): how low the mean reads for one, two and three blocks"),
        (1, "reads the figure (within 3 mm for one block, 7-18 mm low for two, 19-23 mm for three) and explains it "
            "by the side faces the oblique camera sees, a larger share of the mask the taller the stack"),
        (0.5, "predicts (a) straight above: sides edge-on, the mean near the top; (b) near the image border: more "
              "oblique rays, more side, the mean lower")),
    "grab.sag_question": _c(
        (1, "reads the figure: flat 16 mm leaves the tool about 15 mm too high at 150 mm reach and about 5 mm at "
            "450 mm; the report's six locations lay in a narrow band of reach (and had a corrected Zw)"),
        (1, "what would make the joint model worth it: sag depending on the pose at one reach (spread beyond the "
            "reading noise); measure many poses over reach and heights on the real arm and compare residuals")),
    "teach.replay_question": _c(
        (1, "reads the figure: descents and lifts move shoulder, elbow and wrist angle together; waist (and wrist "
            "rotate) move only between the spots"),
        (1, "replay needs no camera or calibration, only the hands, and fails when B is 20 mm off; move_path needs "
            "a detected point per block and still picks B at its centre")),
    "events.tower_question": _c(
        (1, "the points from the figure's block count with the rule, the sum shown (12 blocks: 8 x 30 + 4 x 50 = "
            "440), and 200 fewer with the default clearance (8 blocks: 240)"),
        (1, "what must fit between the top and the highest tool point, in mm (the release gap, the held block below "
            "the tool point and its height, the clearance: about 531 mm against the 511 mm reached, so reach stops "
            "it), one change to gain a block with its risk, and what to measure on the real arm first")),
}

# per question, phrases of its model answer that would answer it: none may stand beside the question in the release
# (its text and code from the figure to the answer cell) or in the outputs a student sees there
# (tests/course/test_written_questions.py)
GIVEAWAYS: dict[str, tuple[str, ...]] = {
    "calib.q_reprojection": ("distortion", "not a projective map"),
    "calib.q_views": ("undistorted pinhole", "not a bias"),
    "fk.q_frames": ("alpha4 = -90°", "no parameter to go into"),
    "fk.q_table_error": ("holds the tool axis vertical", "by the same amount everywhere"),
    "ik.q_branches": ("16° past", "lower limit of −100°"),
    "ik.q_damping": ("hits the max_step clamp", "chatters between"),
    "detect.confusion_question": ("the value floor", "other side of the wrap"),
    "detect.q_stacks": ("seen edge-on", "more oblique"),
    "grab.sag_question": ("15 mm too high",),
    "teach.replay_question": ("needs no camera",),
    "events.tower_question": ("440", "8 x 30 = 240"),
}

# per question, numbers its model answer reads off the figure's cells: each must stand both in the model answer and
# in the stored notebook's printed outputs (tests/course/test_written_questions.py), so a model answer follows the
# figure when the notebook changes
FIGURE_FACTS: dict[str, tuple[str, ...]] = {
    "calib.q_views": ("27 %", "47 px", "7 px with 16"),
    "fk.q_table_error": ("4.9 to 5.4 mm", "16.2 to 16.7 mm"),
    "ik.q_damping": ("in 10 steps", "in 36 steps", "10.0 mm"),
    "events.tower_question": ("12 blocks", "456 mm"),
}


def rubric_of(exercise_id: str) -> tuple[Criterion, ...]:
    """The rubric of a written question (KeyError naming the question when it has none)."""
    if exercise(exercise_id).kind != "written":
        raise KeyError(f"{exercise_id} is not a written question: it is graded by its checks")
    try:
        return RUBRICS[exercise_id]
    except KeyError:
        raise KeyError(f"written question {exercise_id} has no rubric in {__name__}") from None


_missing = [e.id for e in EXERCISES if e.kind == "written" and e.id not in RUBRICS]
_wrong = [i for i, c in RUBRICS.items() if abs(sum(x.points for x in c) - exercise(i).points) > 1e-9]
_missing += [e.id for e in EXERCISES if e.kind == "written" and e.id not in GIVEAWAYS]
if _missing or _wrong:
    raise ValueError(f"written questions without a rubric or give-aways: {_missing}; rubrics whose points differ "
                     f"from the question's: {_wrong}")

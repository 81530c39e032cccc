"""What the public CHECK cells say of each kept wrong answer (tests/course/wrong_answers.py HIDDEN_WRONG), for the
tests of the self-check (test_grading_self_check.py, test_grading_hints.py). Every kept wrong answer is in exactly
one of:
- HINTS: a check fails it, and the first failing check's message names the likely cause (this text is in it);
- CAUSE_UNTOLD: a check fails it, but what the check measures cannot tell this slip from others (the message says
  what is wrong, e.g. the tower's height, not why): no cause is named;
- HIDDEN_ONLY: every public check passes it; the hidden checks fail it (test_hidden_checks*.py).
NEEDS: an exercise whose public checks need another one written (a check cell of both, or one that reads what the
other's code built), which then holds the reference while the first one's wrong answers are checked."""

from __future__ import annotations

from pathlib import Path

from armlab_course.grading.run import Limits

# the limits of the self-check runs of these tests (a notebook 07 or 04 slice under load takes up to a minute)
LIMITS = Limits(timeout_s=400, cpu_s=400)

HINTS = {
    ("detect.classify", "per-class spreads ignored"): "weigh each class's distance by its own spreads",
    ("detect.classify", "margin to the farthest class"): "the margin is to the second-nearest class",
    ("calib.pinhole", "no translation"): "leaves out T_cam_world's translation",
    ("calib.pinhole", "rotation not transposed"): "right with T_cam_world's rotation transposed",
    ("calib.zhang", "rows of H for its columns"): "changes when the board's origin moves",
    ("calib.zhang", "B's sign not fixed"): "refuses exact views it solves in smaller sets",
    ("calib.depth_plane", "one fit, no rejection"): "the same after 1 round as after 6",
    ("calib.depth_plane", "outliers kept"): "the same whatever inlier_mm",
    ("calib.tag_extrinsics", "pixels, not normalised points"): "the same pose whatever K and dist",
    ("calib.tag_extrinsics", "hard-coded"): "the same pose whatever the corners",
    ("calib.tag_homography", "hard-coded"): "the same H whatever the points",
    ("calib.tag_homography", "normalisation not undone"): "undo the normalisation",
    ("fk.dh_link_transform", "d negated"): "right with d negated",
    ("fk.dh_link_transform", "theta and alpha swapped in row 0"): "first in row 0",
    ("fk.dh_table", "alpha1's sign slipped"): "row 1's alpha negated",
    ("fk.dh_table", "the L's tilt added, not taken off"): "row 2's theta offset is off by 2 beta",
    ("fk.euler", "psi's sign slipped"): "right with psi mirrored",
    ("fk.euler", "no singular case"): "a singular case of its own",
    ("ik.candidates", "hard-coded"): "the same first four joints whatever the target",
    ("ik.numerical", "cross product's order swapped (its sign)"): "the velocity of a turning body",
    ("detect.segment", "red's wrap ignored"): "wrong: ['red']",
    ("detect.face", "yaw not wrapped"): "is outside [-pi/4, pi/4)",
    ("detect.face", "size from pixels, not mm"): "mm/px) called 'small'",
    ("detect.stacks", "mean over the whole mask"): "are the sides or the lost depths in your estimate?",
    ("detect.stacks", "levels with one block size"): "a 3-block stack counted 2 high",
    ("grab.click_target", "the face's yaw ignored"): "test the point in the face's own axes",
    ("grab.click_target", "the depth ignored (the first face containing the click)"): "let the click's height decide",
    ("grab.move_path", "release at the grasp height"): "below the board",
    ("grab.move_path", "roll ignores the yaw"): "off square: the pads pinched it on two edges",
    ("grab.sequence", "every block taken as hit (no test of the face)"): "a click on bare board was not refused",
    ("teach.replay", "recorded before posing"): "not at A",
    ("teach.replay", "no velocity floor"): "over its velocity limit",
    ("events.sort_stack", "stack height not tracked"): "into the known block",
    ("events.line_up", "lines too long (50 mm pitch for both sizes, 60 for the large)"): "mm long (>= 300)",
    # on the physics world it keeps trying the 13th level, out of reach, until the time is up
    ("events.sky", "keeps trying after a level out of reach (never stops)"):
        "did the strategy stop once the next level was out of reach",
    ("station.transition", "no stop at the end of the work"): "a stop during the work: heard False",
    ("station.machine", "reset in any state"): "reset during teaching was not refused",
    ("station.machine", "the torque left off after teaching"): "the torque is still off",
}
CAUSE_UNTOLD = {
    ("ik.candidates", "elbow sign swapped"): "the branches found differ from the expected ones; their labels show "
                                             "which, not why",
    ("ik.numerical", "orientation left out of the step"): "the student's own loop stops unconverged (its "
                                                          "NotConverged), before any check can look",
    ("detect.segment", "ranges tuned too tight"): "four colours are missed: too tight and shifted ranges look alike",
    ("grab.sequence", "the held block never forgotten after a drop"): "the kit refuses the second drop; the "
                                                                      "sequence's belief is not observable",
    ("events.line_up", "blocks keep their detected yaw (not square to the line)"): "the line is too long: turned "
                                                                                   "blocks and a wrong pitch alike",
    ("events.sky", "carried at the default 50 mm clearance"): "the tower is lower than expected: any of the "
                                                              "strategy's choices can cost a level",
}
HIDDEN_ONLY = {
    ("ik.numerical", "finite differences, not the exact Jacobian"): "close to 1e-8: the public check's tolerance",
    ("station.transition", "errors always back to idle"): "the public sessions raise no error after a stop",
    ("events.sort_stack", "no unstacking"): "the three public levels need no unstacking",
}
# notebook 02's exercises: their self-check runs in seconds, so test_grading_self_check.py runs it against the grader's
CHEAP = ("fk.dh_link_transform", "fk.dh_table", "fk.euler")
NEEDS = {"calib.tag_extrinsics": "calib.depth_plane", "calib.depth_plane": "calib.tag_extrinsics",
         "station.machine": "station.transition"}


def waits_for_another(check, exercise_id: str) -> bool:
    """A check of two exercises (e.g. '# CHECK calib.tag_extrinsics calib.depth_plane') fails while the other one is
    blank: that is not the region's failure."""
    blank = "ExerciseNotWritten: exercise "
    return check.message.startswith(blank) and not check.message.startswith(f"{blank}{exercise_id} ")


def rounds(exercise_ids: list[str], wrong: dict[str, dict[str, list[str]]]) -> list[dict[str, str | None]]:
    """Submissions that hold every kept wrong answer of `exercise_ids` once, as few notebook runs as can be: each maps
    exercises of one notebook to the label of a wrong answer, or to None for the reference (an exercise another one
    NEEDS); every exercise not named is blank. One notebook per submission: a package slot's wrong answer (the
    calibration's, the IK's) would reach other notebooks through the engine. An exercise and the one it needs are
    never both wrong in one submission, so each wrong answer's checks see only its own slip."""
    from armlab_course.exercises.registry import exercise

    out: list[dict[str, str | None]] = []
    for notebook in sorted({exercise(e).notebook for e in exercise_ids}):
        mine = [e for e in exercise_ids if exercise(e).notebook == notebook]
        free = [e for e in mine if e not in NEEDS]
        for r in range(max((len(wrong[e]) for e in free), default=0)):
            out.append({e: list(wrong[e])[r] for e in free if r < len(wrong[e])})
        groups: list[list[str]] = []
        for e in (e for e in mine if e in NEEDS):
            home = next((g for g in groups if all(NEEDS[e] != d and NEEDS.get(d) != e for d in g)), None)
            if home is None:
                groups.append([e])
            else:
                home.append(e)
        for group in groups:
            for r in range(max(len(wrong[e]) for e in group)):
                out.append({**{NEEDS[e]: None for e in group},
                            **{e: list(wrong[e])[r] for e in group if r < len(wrong[e])}})
    return out


def built_release(tmp_path_factory, name: str) -> Path:
    """A student release of this checkout, built in a new temporary folder `name`."""
    from wrong_answers import ROOT

    from armlab_course.exercises import make_student_release

    folder = tmp_path_factory.mktemp(name) / "release"
    make_student_release(ROOT, folder)
    return folder

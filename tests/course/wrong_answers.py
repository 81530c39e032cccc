"""Wrong answers to every exercise graded by code, for the tests of the grader's hidden checks (test_hidden_checks*.py)
and of its scoring (test_grading.py): each plausible slip a student makes, written into the reference's region; a
"hard-coded" one returns a fixed value. `check_wrong_answers` runs them: the reference passes every hidden check, each
wrong answer fails at least one, a hard-coded one every one."""

from __future__ import annotations

from pathlib import Path

from armlab_course.exercises.registry import exercise
from armlab_course.grading.run import Limits
from armlab_course.grading.submission import exercise_file, regions_of, source_texts

ROOT = Path(__file__).resolve().parents[2]
WRONG_DH = ("    return np.array([[np.pi / 2, h0, 0.0, np.pi / 2], [-(np.pi / 2 - beta), 0.0, L1, 0.0],\n"
            "                     [np.pi / 2 - beta, 0.0, L2, 0.0], [-np.pi / 2, 0.0, 0.0, -np.pi / 2],\n"
            "                     [0.0, Lt, 0.0, 0.0]])")      # alpha1's sign slipped: z1 points the other way


def reference_bodies(exercise_id: str) -> list[str]:
    name = exercise_file(exercise(exercise_id))
    return regions_of(source_texts(ROOT / name), exercise_id, name)


def wrong_euler() -> list[str]:
    # psi's sign slipped: the classic slip reading the third rotation off the bottom row
    body = reference_bodies("fk.euler")[0]
    assert "-R[2, 0]" in body
    return [body.replace("-R[2, 0]", "R[2, 0]")]


def jacobian_by_differences() -> list[str]:
    # tool_jacobian by central differences of fk: close (1e-8), not exact
    bodies = reference_bodies("ik.numerical")
    assert "J[:3, i]" in bodies[0]
    return ["    J = np.zeros((6, 5))\n"
            "    R = kinematics.fk(q, check_limits=False)[:3, :3]\n"
            "    for i in range(5):\n"
            "        step = np.eye(5)[i] * 1e-5\n"
            "        plus, minus = kinematics.fk(np.stack([q + step, q - step]), check_limits=False)\n"
            "        J[:3, i] = (plus[:3, 3] - minus[:3, 3]) / 2e-5\n"
            "        W = (plus[:3, :3] - minus[:3, :3]) / 2e-5 @ R.T\n"
            "        J[3:, i] = [W[2, 1], W[0, 2], W[1, 0]]\n"
            "    return J"] + bodies[1:]


def _replaced(exercise_id: str, old: str, new: str) -> list[str]:
    bodies = reference_bodies(exercise_id)
    assert any(old in b for b in bodies), f"{old!r} not in the reference of {exercise_id}"
    return [b.replace(old, new) for b in bodies]


HIDDEN_WRONG = {   # per exercise: wrong answers its hidden checks must catch (a "hard-coded" one must fail them all)
    "calib.pinhole": {
        "no translation": _replaced("calib.pinhole", " + T_cam_world[:3, 3]", ""),
        "rotation not transposed": _replaced("calib.pinhole", "T_cam_world[:3, :3].T @", "T_cam_world[:3, :3] @"),
    },
    "calib.zhang": {
        "rows of H for its columns": _replaced("calib.zhang", "h1, h2 = G[:, 0], G[:, 1]", "h1, h2 = G[0], G[1]"),
        "B's sign not fixed": _replaced("calib.zhang", "    if B[0, 0] < 0:", "    if False:"),
    },
    "calib.tag_homography": {
        "hard-coded": ["    H = np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])"],
        "normalisation not undone": _replaced("calib.tag_homography", "np.linalg.solve(T_dst, H_normalised @ T_src)",
                                              "H_normalised"),
    },
    "calib.tag_extrinsics": {   # the refinement after the region would repair both: the adapter leaves it out
        "hard-coded": ["    R, t = np.diag([1.0, -1.0, -1.0]), np.array([0.0, 150.0, 1000.0])"],
        "pixels, not normalised points": _replaced("calib.tag_extrinsics",
                                                   "opencv_homography(world[:, :2], normalised)",
                                                   "opencv_homography(world[:, :2], pixels)"),
    },
    "calib.depth_plane": {
        "one fit, no rejection": _replaced("calib.depth_plane", "range(iterations)", "range(1)"),
        "outliers kept": _replaced("calib.depth_plane", "< inlier_mm", "< 1e9"),
    },
    "fk.dh_table": {
        "alpha1's sign slipped": [WRONG_DH],
        "the L's tilt added, not taken off": _replaced("fk.dh_table", "[-(np.pi / 2 - beta), 0.0, L1, 0.0]",
                                                       "[-(np.pi / 2 + beta), 0.0, L1, 0.0]"),
    },
    "fk.euler": {
        "psi's sign slipped": wrong_euler(),
        "no singular case": _replaced("fk.euler", "if sin_theta > 1e-12:", "if True:"),
    },
    "fk.dh_link_transform": {
        "d negated": _replaced("fk.dh_link_transform", "= sa, ca, d", "= sa, ca, -d"),
        "theta and alpha swapped in row 0": _replaced("fk.dh_link_transform", "-st * ca, st * sa", "-ct * sa, st * ca"),
    },
    "ik.candidates": {
        "hard-coded": ["    q1 = q2 = q3 = q4 = heading * 0.0\n    ok, d2 = heading == heading, heading * 0.0 + 1.0"],
        "elbow sign swapped": _replaced("ik.candidates", "* delta_sign", "* -delta_sign"),
    },
    "ik.numerical": {
        # small edits only: this file ships in the student release
        "cross product's order swapped (its sign)": _replaced("ik.numerical", "J[:3, i] = ", "J[:3, i] = -"),
        "orientation left out of the step": _replaced("ik.numerical", "weight_mm, weight_mm, weight_mm])",
                                                      "0.0, 0.0, 0.0])"),
        "finite differences, not the exact Jacobian": jacobian_by_differences(),
    },
    "detect.segment": {
        "red's wrap ignored": _replaced("detect.segment", "if h0 <= h1:", "if True:"),
        "ranges tuned too tight": _replaced("detect.segment", "120, 60)", "250, 250)"),
    },
    "detect.face": {
        "yaw not wrapped": _replaced("detect.face", "yaw = (np.radians(angle) + np.pi / 4) % (np.pi / 2) - np.pi / 4",
                                     "yaw = np.radians(angle)"),
        "size from pixels, not mm": _replaced("detect.face", "edge_mm = np.sqrt(m[\"m00\"]) * mm_per_px",
                                              "edge_mm = np.sqrt(m[\"m00\"])"),
    },
    "detect.classify": {
        "per-class spreads ignored": _replaced(
            "detect.classify", "d = np.sqrt((((X[:, None, :] - self.means[None]) / self.stds[None]) ** 2).sum(-1))",
            "d = np.linalg.norm(X[:, None, :] - self.means[None], axis=-1)"),
        "margin to the farthest class": _replaced("detect.classify", "d[rows, order[:, 1]] - d[rows, order[:, 0]]",
                                                  "d[rows, order[:, -1]] - d[rows, order[:, 0]]"),
    },
    "detect.stacks": {
        "mean over the whole mask": _replaced("detect.stacks", "top_z = float(np.median(central[:, 2]))",
                                              "top_z = float(np.mean(z))"),
        "levels with one block size": _replaced(
            "detect.stacks", "levels = min(n for n, h in candidates if abs(top_z - h) <= best + 1.5)",
            "levels = max(1, round(top_z / large))"),
    },
    "grab.click_target": {
        "the face's yaw ignored": _replaced(
            "grab.click_target", "    along = cos * offset[:, 0] + sin * offset[:, 1]       # the offset in each "
            "face's own axes\n    across = -sin * offset[:, 0] + cos * offset[:, 1]", "    along, across = offset.T"),
        "the depth ignored (the first face containing the click)": _replaced(
            "grab.click_target", "return int(hit[np.argmin(height_gap)])", "return int(hit[0])"),
    },
    "grab.sequence": {
        "every block taken as hit (no test of the face)": _replaced(
            "grab.sequence", "hit = [b for b in seen if b.is_block and under_click(b)]",
            "hit = [b for b in seen if b.is_block]"),
        "the held block never forgotten after a drop": _replaced(
            "grab.sequence", "\n        elif ok:\n            self.held = None", ""),
    },
    "grab.move_path": {
        "roll ignores the yaw": _replaced("grab.move_path",
                                          "roll = planning.tilted_roll(heading, float(pitch), float(yaw))",
                                          "roll = 0.0"),
        "release at the grasp height": _replaced("grab.move_path", "tool_z = target[2] + edge - depth",
                                                 "tool_z = target[2] - depth"),
    },
    "teach.replay": {
        "recorded before posing": _replaced("teach.replay", "arm.move_by_hand(q)\n            recorder.record(g)",
                                            "recorder.record(g)\n            arm.move_by_hand(q)"),
        "no velocity floor": _replaced("teach.replay", "np.maximum(np.maximum(lab_pace, velocity_floor), 0.4)",
                                       "np.maximum(lab_pace, 0.4)"),
    },
    "events.sort_stack": {
        "no unstacking": _replaced("events.sort_stack", "if standing_on_something:", "if False:"),
        "stack height not tracked": _replaced("events.sort_stack", "len(built[b.size]) * block_edge(b.size)", "0.0"),
    },
    "events.line_up": {
        "lines too long (50 mm pitch for both sizes, 60 for the large)": _replaced(
            "events.line_up", 'pitch = {"large": 50.0, "small": 40.0}', 'pitch = {"large": 60.0, "small": 50.0}'),
        "blocks keep their detected yaw (not square to the line)": _replaced(
            "events.line_up", 'Move(b, slot.copy(), 0.0, "line")', 'Move(b, slot.copy(), float(b.yaw), "line")'),
    },
    "events.sky": {
        "carried at the default 50 mm clearance": _replaced("events.sky", '0.0, "tower", 15.0)', '0.0, "tower")'),
        "keeps trying after a level out of reach (never stops)": _replaced(
            "events.sky", '        self.stopped = f"the next level is out of reach: {why}"\n', ""),
    },
    "station.machine": {
        "the torque left off after teaching": _replaced("station.machine", "            self.port.set_torque(True)\n",
                                                        ""),
        "reset in any state": _replaced("station.machine",
                                        'if self.state != "estop":\n                raise MachineBusy(f"reset',
                                        'if False:\n                raise MachineBusy(f"reset'),
    },
    "station.transition": {
        "no stop at the end of the work": _replaced("station.transition", "    if machine.stop_requested:\n",
                                                    "    if False:\n"),
        "errors always back to idle": _replaced("station.transition", "if not machine.stop_requested:\n", "if True:\n"),
    },
}
# the exercises whose hidden checks run the simulator at length (tested apart: test_hidden_checks_open.py). Each run
# of check_wrong_answers runs every one of them, so its cost is the number of runs (wrong_sets: 4 for these 6; the
# tuned segmentation, 3 s a run, is held by test_hidden_checks.py, where it adds no run: a 7th here made it 5)
OPEN_TASKS = ("events.sort_stack", "events.line_up", "events.sky", "grab.move_path", "grab.sequence", "teach.replay")
# exercises whose hidden checks call another exercise's region, so that the other one's wrong answer fails them too;
# the grader then runs the exercise again alone, the reference in place of the rest (Grader.grade). None is left:
# kinematics.fk is the PoX model (ik.numerical no longer calls dh_link_transform), the check of calib.tag_extrinsics
# runs the kit's homography in place of the student's dlt_homography (adapters._call_initial_pose), and the station's
# machine runs the kit's stand-in transition in place of the student's run_command (adapters._call_machine)
DEPENDS: dict[str, set[str]] = {}


def wrong_sets(ids: list[str]) -> list[list[str]]:
    """Runs of the hidden checks, each a set of exercises given a wrong answer (the rest the reference), such that
    every wrong answer of HIDDEN_WRONG runs (each exercise is wrong in as many runs as it has wrong answers, or more)
    and, for every ordered pair (x, y) of `ids`, some run has x wrong and y not: the exercises' sets of runs are
    distinct s-subsets of range(k), which no two contain one another, for the fewest runs k (s < k)."""
    from itertools import combinations
    from math import comb

    least = max(len(HIDDEN_WRONG[e]) for e in ids)
    k = least + 1
    while not any(comb(k, s) >= len(ids) for s in range(least, k)):
        k += 1
    s = next(s for s in range(least, k) if comb(k, s) >= len(ids))
    chosen = list(combinations(range(k), s))[:len(ids)]
    return [[e for e, runs in zip(ids, chosen, strict=True) if run in runs] for run in range(k)]


def check_wrong_answers(ids: list[str], blank: list[str] = ()) -> None:
    """The hidden checks of these exercises: the reference (in one harness run after the one computing the expected
    values) passes every one; then, in the runs of wrong_sets (each exercise wrong in some of them, its wrong answers
    in turn), each wrong answer fails at least one of its exercise's checks (a hard-coded one every check), and every
    exercise at its reference passes all of its checks unless it calls (DEPENDS) an exercise that is wrong in that
    run: a wrong answer costs its own exercise only. Each declared dependency is seen failing once (DEPENDS is true).
    The exercises of `blank` fail every hidden check with their blank stubs (in one run)."""
    from armlab_course.grading.grade import Grader

    grader = Grader(ROOT, Limits(timeout_s=300, cpu_s=200), ids)
    try:
        reference = grader.hidden_checks_together({e: reference_bodies(e) for e in ids})
        for exercise_id in ids:
            checks = reference[exercise_id]
            # at least two hidden checks each (events.sky builds two towers: each is minutes of simulation)
            assert len(checks) >= 2 and all(c.passed for c in checks), (exercise_id, [c.message for c in checks])
        if blank:
            got = grader.hidden_checks_together({e: blank_bodies(e) for e in blank})
            for exercise_id in blank:
                assert got[exercise_id] and not any(c.passed for c in got[exercise_id]), \
                    (exercise_id, "blank", [c.passed for c in got[exercise_id]])
        used = {e: 0 for e in ids}
        dependents_failed = set()
        for wrong in wrong_sets(ids):
            answers = {}
            for e in wrong:
                answers[e] = list(HIDDEN_WRONG[e].items())[used[e] % len(HIDDEN_WRONG[e])]
                used[e] += 1
            got = grader.hidden_checks_together(
                {e: answers[e][1] if e in answers else reference_bodies(e) for e in ids})
            for exercise_id, (label, _) in answers.items():
                passed = [c.passed for c in got[exercise_id]]
                assert not all(passed), f"{exercise_id}, {label}: every hidden check passed"
                assert not (label == "hard-coded" and any(passed)), f"{exercise_id}, {label}: {passed}"
            for other in set(ids) - set(answers):
                if DEPENDS.get(other, set()) & set(answers):
                    if not all(c.passed for c in got[other]):
                        dependents_failed.add(other)
                    continue
                assert all(c.passed for c in got[other]), \
                    (f"{other} (at its reference) failed while {sorted(answers)} were wrong",
                     [c.message for c in got[other] if not c.passed])
        assert all(used[e] >= len(HIDDEN_WRONG[e]) for e in ids), f"a wrong answer never ran: {used}"
        declared = {e for e, needs in DEPENDS.items() if e in ids and needs <= set(ids)}
        assert dependents_failed == declared, f"DEPENDS is stale: {declared - dependents_failed} never failed"
    finally:
        grader.close()


def check_each_wrong_loses_only_its_own(grader, ids, round_: int) -> None:
    """Each exercise of `ids` wrong in turn (its round_-th wrong answer) while the others hold the reference, in one
    harness run per exercise (`grader`: a Grader of these exercises): the wrong one fails a hidden check, the others
    pass every one."""
    for wrong_id in ids:
        label, bodies = list(HIDDEN_WRONG[wrong_id].items())[round_]
        got = grader.hidden_checks_together({e: bodies if e == wrong_id else reference_bodies(e) for e in ids})
        assert not all(c.passed for c in got[wrong_id]), f"{wrong_id}, {label}: every hidden check passed"
        for other in ids:
            if other != wrong_id:
                assert all(c.passed for c in got[other]), (other, label, [c.message for c in got[other]])


def blank_bodies(exercise_id: str) -> list[str]:
    """The exercise's regions as the student release holds them: each the stub, at its reference's indentation."""
    from armlab_course.exercises.markers import stub_lines

    out = []
    for body in reference_bodies(exercise_id):
        first = next(line for line in body.splitlines() if line.strip())
        indent = first[:len(first) - len(first.lstrip())]
        out.append("\n".join(indent + line for line in stub_lines(exercise_id)))
    return out


def check_alone(exercise_id: str, limits: Limits | None = None) -> None:
    """The exercise's hidden checks with only its own region changed (every other at the reference): the reference
    passes every one, the blank stub none, and each of its wrong answers (HIDDEN_WRONG) fails at least one."""
    from armlab_course.grading.grade import Grader

    grader = Grader(ROOT, limits or Limits(timeout_s=1200, cpu_s=600), [exercise_id])
    try:
        reference = grader.hidden_checks_together({exercise_id: reference_bodies(exercise_id)})[exercise_id]
        assert len(reference) >= 2 and all(c.passed for c in reference), \
            (exercise_id, [c.message for c in reference if not c.passed])
        blank = grader.hidden_checks_together({exercise_id: blank_bodies(exercise_id)})[exercise_id]
        assert blank and not any(c.passed for c in blank), (exercise_id, "blank", [c.passed for c in blank])
        for label, bodies in HIDDEN_WRONG[exercise_id].items():
            got = grader.hidden_checks_together({exercise_id: bodies})[exercise_id]
            assert got and not all(c.passed for c in got), f"{exercise_id}, {label}: every hidden check passed"
    finally:
        grader.close()

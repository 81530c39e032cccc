"""The hidden checks of the exercises graded by comparison with the reference (every one but the open tasks of
test_hidden_checks_open.py): the reference passes them, plausible wrong answers fail them
(tests/course/wrong_answers.py); every exercise has them; the static check names a forbidden call; an open task's
outcome is compared with all ones."""

from __future__ import annotations

import numpy as np
import pytest
from wrong_answers import HIDDEN_WRONG, OPEN_TASKS, check_wrong_answers, reference_bodies


def test_every_exercise_has_hidden_checks_and_wrong_answers():
    from armlab_course.exercises.registry import EXERCISES
    from armlab_course.grading import hidden

    graded_by_code = sorted(e.id for e in EXERCISES if e.kind != "written")
    assert sorted(hidden.SPECS) == graded_by_code == sorted(HIDDEN_WRONG)
    assert sorted(hidden.FORBIDDEN) == graded_by_code
    assert all(len(wrong) >= 2 for wrong in HIDDEN_WRONG.values()), "each exercise has two plausible wrong answers"


def test_hidden_checks_pass_the_reference_and_fail_wrong_answers():
    check_wrong_answers(sorted(set(HIDDEN_WRONG) - set(OPEN_TASKS)))


def test_static_check_names_the_forbidden_call():
    """Every reference region passes; each exercise's forbidden names and the kit's reference module, called,
    imported, aliased or named in a string, fail the check with the name; the region's own names do not count."""
    from armlab_course.exercises.registry import EXERCISES
    from armlab_course.grading.hidden import FORBIDDEN
    from armlab_course.grading.static import forbidden_uses, static_check

    for ex in (e for e in EXERCISES if e.kind != "written"):
        assert static_check(ex.id, reference_bodies(ex.id)).passed, ex.id
        for name in FORBIDDEN[ex.id]:
            module, _, last = name.rpartition(".")
            module = module or "lib"
            uses = [f"    x = {module}.{last}(1)", f"    from {module} import {last}\n    x = {last}(2)",
                    f"    f = getattr({module}, {last!r})"]
            for body in uses:
                result = static_check(ex.id, [body])
                assert not result.passed and name in result.message, (ex.id, body, result)
    ref = static_check("teach.replay", ["    from armlab_course.exercises import references\n"
                                             "    return references.scaled_durations_by_search(program, speed)"])
    assert not ref.passed and "armlab_course.exercises.references" in ref.message
    assert forbidden_uses("    fk = 1.0\n    return fk * 2", ("kinematics.fk",)) == []      # its own variable
    assert forbidden_uses("    return sky_points(n - 1) + 30", ("scoring.sky_points",), ("sky_points",)) == []
    assert forbidden_uses("    if x:\n        pass\n    H = cv2.findHomography(a, b)",
                          ("cv2.findHomography",)) == [("cv2.findHomography", 3)]


@pytest.mark.parametrize("value, said", [([1.0, 1.0], ""),
                                         ([1.0, 0.0], "not met: within the time limit (1 of 2 criteria not met)"),
                                         ([0.5, 1.0], "not met: full marks (1 of 2 criteria not met)"),
                                         ([], "the result: empty")])
def test_an_open_tasks_outcome_passes_only_when_every_criterion_is_met(value, said):
    """An outcome spec has no reference run: a result passes when every number of it is 1.0 (a criterion met), and
    an empty one (no criterion at all) fails; the message names the first criterion not met."""
    from armlab_course.grading.hidden import compare, specs_of

    spec = specs_of("events.sort_stack")[0]
    assert spec.outcome
    (ok, message), = compare(spec, [{"value": [1.0, 1.0]}, {"value": value}], None, [2])
    assert ok == (not said) and message == (f"hidden check 1, call 2: {said}" if said else ""), message


def test_a_failed_hidden_check_names_the_property_its_size_and_unit_not_the_inputs():
    """Issue 34: 'the result differs from the expected value' told a student nothing. A miss names what was
    compared, the part that misses most with its unit, the size (2 significant digits) and the tolerance; a
    pass/fail result names its first criterion not met (and the block); another shape says both shapes."""
    from armlab_course.exercises.registry import EXERCISES
    from armlab_course.grading.hidden import compare, how_it_differs, specs_of

    pixels = specs_of("calib.pinhole")[0]
    (ok, message), = compare(pixels, [{"value": [[10.0, 20.0], [30.0, 41.25]]}],
                             [{"value": [[10.0, 20.0], [30.0, 40.0]]}], [1])
    assert not ok and message == ("hidden check 1, call 1: the projected pixels (u, v): off by up to 1.2 px "
                                  "(tolerance 1e-06 px)"), message
    euler = specs_of("fk.euler")[0]
    said = how_it_differs(euler, np.array([1.0, 0.0, 0.5, 1.0, 0.0]), np.array([1.0, 0.0, 0.25, 1.0, 0.0]))
    assert said == "the Euler angles (theta): off by up to 0.25 rad (tolerance 1e-07 rad)", said
    moves = specs_of("grab.move_path")[0]
    said = how_it_differs(moves, np.array([1.0, 1.0, 1.0, 0.0, 0.0, 0.0]), np.ones(6))
    assert said == "block 2: not met: landed within 3 mm of its spot (3 of 6 criteria not met)", said
    assert how_it_differs(pixels, np.zeros((3, 2)), np.zeros((4, 2))) == \
        "the projected pixels (u, v): shape (3, 2), expected (4, 2)"
    clicks = specs_of("grab.click_target")[0]
    assert how_it_differs(clicks, np.array([1.0, 2.0, 3.0]), np.array([1.0, 0.0, 3.0])) == \
        "the index of the block hit: 1 of its 3 numbers differ from the expected"
    for e in EXERCISES:
        for spec in specs_of(e.id):
            assert spec.what != "the result" or spec.criteria, f"{e.id}: {spec.function} names no property"


def test_the_wire_carries_plain_data_only():
    """Arrays cross the judge's pipe as bytes with a dtype and a shape, and come back equal; a message naming a
    dtype outside the list (an object array: pickle), a byte count that does not fit the shape, or a line that is no
    JSON object is refused."""
    import base64

    import numpy as np

    from armlab_course.grading.wire import WireError, decode, dumps, encode, loads

    image = np.arange(720 * 1280, dtype=np.uint16).reshape(720, 1280) % 977
    sent = loads(dumps({"value": encode([image, np.float32(2.5), (1, "large", None)])}))
    got = decode(sent["value"])
    assert isinstance(sent["value"][0], dict) and got[0].dtype == np.uint16 and np.array_equal(got[0], image)
    assert got[1:] == [2.5, [1, "large", None]]
    raw = base64.b64encode(b"\x80\x04N.").decode()
    for bad in ({"ndarray": raw, "dtype": "object", "shape": [1]}, {"ndarray": raw, "dtype": "float64", "shape": [9]}):
        with pytest.raises(WireError):
            decode(bad)
    for line in (b"[1, 2]", b"not json", b"{" * 100_000):
        with pytest.raises(WireError):
            loads(line)


_CHILD = '''
import json, sys, time
first = json.loads(sys.stdin.readline())
nonce, mode = first["nonce"], sys.argv[1]
print(json.dumps({"nonce": nonce, "ready": len(first["jobs"])}), flush=True)
for line in sys.stdin:
    request = json.loads(line)
    if request.get("end"):
        break
    answer = {"nonce": nonce, "seq": request["seq"], "value": sum(request["args"]), "forbidden": []}
    if request["seq"] == 2:
        if mode == "other nonce":
            answer["nonce"] = "0" * 32
        elif mode == "out of turn":
            answer["seq"] = 1
        elif mode == "garbage":
            print("not json", flush=True)
            continue
        elif mode == "silent":
            time.sleep(30)
        elif mode == "ends":
            sys.exit(0)
        elif mode == "raises":
            answer = {"nonce": nonce, "seq": 2, "error": "ValueError: the student's", "forbidden": ["cv2.x"]}
    print(json.dumps(answer), flush=True)
'''


@pytest.mark.parametrize("mode", ["honest", "raises", "other nonce", "out of turn", "garbage", "silent", "ends"])
def test_the_judge_takes_only_this_runs_answers_in_turn(mode):
    """A child (a plain process speaking the protocol) that answers the second call with another run's nonce, out of
    turn, with no JSON, not at all before the deadline, or not at all since it ended: the first call keeps its
    value, the second and every later one fail with the reason, and the judge returns; a student's error fails its
    call alone and its forbidden calls are kept."""
    import subprocess
    import sys
    import time

    from armlab_course.grading.judge import run_jobs

    proc = subprocess.Popen([sys.executable, "-c", _CHILD, mode], stdin=subprocess.PIPE, stdout=subprocess.PIPE)
    try:
        jobs = [{"function": "f", "forbidden": [], "cases": [[1, 2], [3, 4]]},
                {"function": "g", "forbidden": [], "cases": [[5, 6]]}]
        out, problem = run_jobs(proc, jobs, time.monotonic() + 3.0)
    finally:
        proc.kill()
        proc.wait()
    first, second, third = out[0]["results"][0], out[0]["results"][1], out[1]["results"][0]
    assert first == {"value": 3}
    if mode == "honest":
        assert (second, third, problem) == ({"value": 7}, {"value": 11}, "")
    elif mode == "raises":
        assert second == {"error": "ValueError: the student's", "where": []} and third == {"value": 11} and not problem
        assert out[0]["forbidden"] == ["cv2.x"]
    else:
        assert problem and second == third == {"error": problem}, (mode, out, problem)

"""Red team of the tripwire (issue 32): a region that reaches the kit's or a library's answer by a name built at run
time, through exec or eval, or by loading a module itself (a second copy of a kit module, a module nothing had
loaded yet, a notebook's own helper) earns nothing -- the static check (armlab_course.grading.static) or the
harness's run-time watch (armlab_course.grading.harness: tripwires and the audit hook) fails it -- and the
reference pasted with renamed variables is flagged in the similarity report.

The watch's own tests run it in a child Python (it wires cv2 and installs an audit hook that cannot be removed);
the end-to-end ones grade the attacks' hidden checks in the grader's sandbox."""

from __future__ import annotations

import inspect
import json
import subprocess
import sys
import textwrap

import pytest
from copies import disguised
from wrong_answers import ROOT, reference_bodies

from armlab.slots import is_standin_for
from armlab_course.exercises.registry import EXERCISES
from armlab_course.grading.hidden import FORBIDDEN
from armlab_course.grading.static import STATIC_CHECK, run_time_code, static_check

CODED = [e.id for e in EXERCISES if e.kind != "written"]

# A child Python: a CallWatch of `names`, the student's code compiled as a notebook cell is ("<ipython-input-...>"),
# the attack called inside the watch, and what the watch saw printed as JSON.
CHILD = '''
import json, sys
import numpy as np
from armlab_course.grading.harness import CallWatch
loaded = "armlab.calibration.extrinsics" in sys.modules
watch = CallWatch(NAMES)
space = {"np": np}
exec(compile(STUDENT, "<ipython-input-1-attack>", "exec"), space)
src = np.array([[0.0, 0.0], [100.0, 0.0], [100.0, 80.0], [0.0, 80.0], [30.0, 40.0]])
dst = src * 1.5 + [10.0, -4.0]
error = ""
with watch:
    try:
        space["student"](src, dst)
    except Exception as e:               # the attack's own failure: the watch has seen what it saw
        error = repr(e)
print(json.dumps({"seen": sorted(set(watch.seen)), "wired": sorted(watch.names), "loaded_before": loaded,
                  "error": error}))
'''

ATTACKS = {      # name: (forbidden names, the student's function)
    "built-up name": (["homography.opencv_homography"], '''
def student(src, dst):
    import armlab.calibration.homography as m
    return getattr(m, "opencv" + "_homo" + "graphy")(src, dst)
'''),
    "through a library's callback": (["cv2.findHomography"], '''
def student(src, dst):
    import contextlib, cv2
    with contextlib.ExitStack() as stack:          # contextlib's own code makes the call
        stack.callback(getattr(cv2, "find" + "Homography"), src, dst, 0)
'''),
    "exec of a string": (["cv2.findHomography"], '''
def student(src, dst):
    space = {"s": src, "d": dst}
    getattr(np, "__dict__")["__builtins__"]["ex" + "ec"]("import cv2\\nH = cv2.findHomography(s, d, 0)[0]", space)
    return space["H"]
'''),
    "a fresh copy of the kit module": (["homography.opencv_homography"], '''
def student(src, dst):
    import importlib.util, armlab.calibration.homography as h
    spec = importlib.util.spec_from_file_location("fresh_copy", h.__file__)
    fresh = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(fresh)
    return fresh.opencv_homography(src, dst)
'''),
    "a reload": (["homography.opencv_homography"], '''
def student(src, dst):
    import importlib, armlab.calibration.homography as h
    return importlib.reload(h).opencv_homography(src, dst)
'''),
    "the kit's source compiled under its own name": (["homography.opencv_homography"], '''
def student(src, dst):
    import armlab.calibration.homography as h
    space = {"__name__": "armlab.calibration.homography"}
    exec(compile(open(h.__file__).read(), h.__file__, "exec"), space)
    return space["opencv_homography"](src, dst)
'''),
    "a module nothing had loaded yet": (["extrinsics._opencv_pose"], '''
def student(src, dst):
    import importlib
    module = importlib.import_module("armlab.calibration." + "extrinsics")
    world = np.column_stack([src, np.zeros(len(src))])
    K = np.array([[600.0, 0, 320], [0, 600.0, 240], [0, 0, 1]])
    return getattr(module, "_opencv" + "_pose")(world, dst + 200, K, np.zeros(5))
'''),
    "a library nothing had loaded yet": (["IKinSpace"], '''
def student(src, dst):
    import importlib
    library = importlib.import_module("modern" + "_robotics")
    return getattr(library, "IKin" + "Space")(np.eye(6), np.eye(4), np.eye(4), np.zeros(6), 0.01, 0.001)
'''),
}
# what must not be charged: the kit calling the forbidden function for itself, a kit dataclass's generated code,
# and plain numerical code (re.compile is no exec)
HONEST = {
    "the kit's own call": (["cv2.findHomography"], '''
def student(src, dst):
    import armlab.calibration.homography as h
    return h.opencv_homography(src, dst)
'''),
    "plain code": (["cv2.findHomography", "homography.opencv_homography"], '''
def student(src, dst):
    import re
    re.compile("[0-9]+").findall("12 34")
    A = np.column_stack([src, np.ones(len(src))])
    return np.linalg.lstsq(A, dst, rcond=None)[0]
'''),
}


def _watched(names: list[str], student: str) -> dict:
    code = CHILD.replace("NAMES", repr(names)).replace("STUDENT", repr(textwrap.dedent(student)))
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT, timeout=300)
    assert done.returncode == 0, done.stderr[-2000:]
    return json.loads(done.stdout.strip().splitlines()[-1])


@pytest.mark.parametrize("attack", list(ATTACKS))
def test_the_watch_sees_the_attack(attack):
    names, student = ATTACKS[attack]
    got = _watched(names, student)
    assert got["wired"] == sorted(names), got            # every forbidden name found, its module loaded or not
    assert got["seen"], f"{attack}: the watch saw nothing"
    if attack == "a module nothing had loaded yet":
        assert not got["loaded_before"]
    if attack in ("a fresh copy of the kit module", "a reload"):
        assert "a second copy of homography.py" in got["seen"], got
    if attack == "exec of a string":
        assert got["seen"] == ["cv2.findHomography", "exec/eval/compile"], got
    if attack == "the kit's source compiled under its own name":
        assert "the kit's homography.py compiled again" in got["seen"], got


@pytest.mark.parametrize("case", list(HONEST))
def test_the_watch_charges_nothing_honest(case):
    names, student = HONEST[case]
    assert _watched(names, student)["seen"] == []


def test_the_static_check_refuses_code_built_or_loaded_at_run_time():
    flagged = {"    exec(text)": "exec", "    H = eval('np.eye(3)')": "eval", "    import importlib": "importlib",
               "    m = __import__('cv2')": "__import__", "    from runpy import run_path": "runpy",
               "    f = dlt_homography.__globals__['cv2']": "__globals__", "    g = globals()['np']": "globals",
               "    code = compile(text, 'x', 'exec')": "compile", "    import builtins": "builtins"}
    for body, name in flagged.items():
        assert [n for n, _ in run_time_code(body)] == [name], body
        check = static_check("calib.tag_homography", [body])
        assert not check.passed and f"uses {name} (line 1" in check.message
    for body in ("    pattern = re.compile('[0-9]+')", "    evaluate = 3\n    x = evaluate + 1",
                 "    def compile(x):\n        return x\n    compile(1)"):
        assert run_time_code(body) == [], body


@pytest.mark.parametrize("exercise_id", CODED)
def test_every_reference_passes_the_static_check(exercise_id):
    check = static_check(exercise_id, reference_bodies(exercise_id))
    assert check is None or check.passed, check


def test_every_stand_in_is_forbidden_to_its_own_exercise():
    """A blank slot's stand-in (armlab.slots.standin: the kit's other method) is its exercise's answer by another
    route: each one is in its exercise's forbidden list, so calling it by any name earns nothing."""
    import armlab.calibration as calibration
    import armlab.detection.color as color
    import armlab.kinematics as kinematics

    found = {}
    for module in (calibration.homography, calibration.extrinsics, calibration.depth, kinematics, color):
        for _, member in [*inspect.getmembers(module), *inspect.getmembers(color.ColorModel)]:
            slot = is_standin_for(member)
            if slot:
                reference = dict(zip(member.__code__.co_freevars,
                                     (c.cell_contents for c in member.__closure__ or ()), strict=True))["reference"]
                found[slot] = reference.__name__
    assert set(found) >= {"calib.tag_homography", "calib.tag_extrinsics", "calib.depth_plane",
                          "fk.dh_link_transform", "ik.candidates", "detect.classify"}, found
    for slot, name in found.items():
        assert any(f.rsplit(".", 1)[-1] == name for f in FORBIDDEN[slot]), (slot, name, FORBIDDEN[slot])


def test_the_reference_pasted_with_renamed_variables_is_flagged_for_every_exercise():
    from armlab_course.grading.similarity import FLAG_AT, similarity_rows

    reference = {e: reference_bodies(e) for e in CODED}
    copier = {e: [disguised(b) for b in bodies] for e, bodies in reference.items()}
    rows = similarity_rows({"copier": copier}, reference)
    against = {e: s for student, e, matched, s in rows if student == "copier" and matched == "reference"}
    missed = {e: round(against.get(e, 0.0), 3) for e in CODED if against.get(e, 0.0) < FLAG_AT}
    assert not missed, f"renamed copies of the reference not flagged (score < {FLAG_AT}): {missed}"


# -- end to end: the attacks' hidden checks in the grader's sandbox -----------------------------------------------
E2E = {   # calib.tag_homography's region: H from src, dst (N, 2); each evades the static check
    "built-up name": '''
    import armlab.calibration.homography as m
    H = getattr(m, "opencv" + "_homo" + "graphy")(src, dst)
''',
    "exec of a string": '''
    space = {"s": src, "d": dst}
    getattr(np, "__dict__")["__builtins__"]["ex" + "ec"]("import cv2\\nH = cv2.findHomography(s, d, 0)[0]", space)
    H = space["H"]
''',
    "a fresh copy of the kit module": '''
    loads = getattr(np, "__dict__")["__builtins__"]["__imp" + "ort__"]("importlib.util", fromlist=["x"])
    import armlab.calibration.homography as h
    spec = getattr(loads, "spec_from_" + "file_location")("fresh_copy", h.__file__)
    fresh = getattr(loads, "module_from_" + "spec")(spec)
    getattr(spec.loader, "exec_" + "module")(fresh)
    H = getattr(fresh, "opencv_" + "homography")(src, dst)
''',
}


@pytest.fixture(scope="module")
def grader():
    from armlab_course.grading.grade import Grader
    from armlab_course.grading.run import Limits

    with Grader(ROOT, Limits(timeout_s=300, cpu_s=200), ["calib.tag_homography", "fk.dh_table"]) as own:
        yield own


@pytest.mark.parametrize("attack", list(E2E))
def test_an_attack_that_passes_the_static_check_earns_nothing(grader, attack):
    from armlab_course.grading.results import score_exercise

    body = textwrap.dedent(E2E[attack]).strip("\n")
    body = textwrap.indent(body, "    ")
    static = static_check("calib.tag_homography", [body])
    assert static.passed, static.message                          # the static check alone would let it through
    checks = grader.hidden_checks("calib.tag_homography", [body])
    caught = [c for c in checks if c.name == STATIC_CHECK]
    assert caught and not caught[0].passed and "at run time" in caught[0].message, [(c.name, c.message)
                                                                                     for c in checks]
    assert score_exercise("calib.tag_homography", checks).score == 0


def test_a_notebook_helper_reached_by_a_built_up_name_earns_nothing(grader):
    """fk.dh_table: notebook 02's own stand-in pox_of_lengths (the PoX model with the lengths put in), fetched from
    the notebook's namespace by a built-up name: the harness wires the notebook's helpers after its cells ran."""
    body = '    return getattr(dh_table, "__glob" + "als__")["pox_of" + "_lengths"](h0, L1, beta, L2, Lt)'
    assert static_check("fk.dh_table", [body]).passed
    checks = grader.hidden_checks("fk.dh_table", [body])
    caught = [c for c in checks if c.name == STATIC_CHECK]
    assert caught and "pox_of_lengths" in caught[0].message, [(c.name, c.message) for c in checks]
    from armlab_course.grading.results import score_exercise

    assert score_exercise("fk.dh_table", checks).score == 0


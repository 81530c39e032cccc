"""The grader against students who want marks without the work (issue 22): each attack is a submission, graded in one
class with honest classmates (two jobs at once, so an attack and a classmate run side by side), and scores what the
honest equivalent deserves; classmates' grades and the instructor's checkout are unchanged; no process of a run
survives it. The sandbox is the one the grader picks here (bubblewrap; `make test` installs it).

The exercises are two notebook exercises of notebook 02: the Euler angles of a pose (attacked) and the DH table
(written as the reference beside it)."""

from __future__ import annotations

import csv
import hashlib
import json
import os
import shutil
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest

from armlab_course.exercises import make_student_release
from armlab_course.exercises.registry import exercise
from armlab_course.grading import grade_class
from armlab_course.grading.run import Limits
from armlab_course.grading.sandbox import SandboxUnavailable, detect
from armlab_course.grading.splice import check_body, write_regions
from armlab_course.grading.submission import exercise_file, read_submission, regions_of, source_texts

ROOT = Path(__file__).resolve().parents[2]
DH, CHAIN = "fk.euler", "fk.dh_table"
GRADED = [DH, CHAIN]
MARK = "armlab-attack-7f3c"          # in every process an attack starts: none may be left after the run
EYE = "    return np.zeros(3)"      # the honest "no work" answer


def _reference(exercise_id: str) -> list[str]:
    name = exercise_file(exercise(exercise_id))
    return regions_of(source_texts(ROOT / name), exercise_id, name)


def _body(code: str) -> str:
    return textwrap.indent(textwrap.dedent(code).strip("\n"), "    ")


BEGIN = "# BEGIN " + "SOLUTION " + DH      # built so that these lines are no markers themselves
READ_SOLUTION = _body(f'''
    import json, os, sys
    from pathlib import Path
    places = [Path.cwd(), *Path.cwd().parents, Path(sys.executable).parents[2], Path("/autograder/source"),
              Path({str(ROOT)!r})]
    for pid in os.listdir("/proc"):
        if pid.isdigit():
            try:
                places.append(Path(os.readlink(f"/proc/{{pid}}/cwd")))
            except OSError:
                pass
    for place in places:
        try:
            cells = json.loads((place / "notebooks/02_forward_kinematics.ipynb").read_text())["cells"]
        except (OSError, ValueError):
            continue
        for cell in cells:
            text = "".join(cell["source"])
            if {BEGIN!r} in text and "np.hypot" in text:
                body = text.split({BEGIN!r})[1].split("# END " + "SOLUTION")[0]
                space = {{"np": np}}
                exec("def solution(T):\\n" + body, space)
                return space["solution"](T)
    raise RuntimeError("no solution found")
''')
CHANGE_GRADER = _body(f'''
    from pathlib import Path
    import armlab
    for root in (Path(armlab.__file__).parent, Path({str(ROOT)!r}) / "armlab"):
        for path in (root / "grading").glob("*.py"):
            try:
                with open(path, "a") as f:
                    f.write("\\n# {MARK}\\n_score = lambda e, c, r='': __import__('armlab').grading.results"
                            ".ExerciseResult(e, 5.0, 5, c, r)\\n")
            except OSError:
                pass
    return np.zeros(3)
''')
def _daemon(loop_body: str) -> str:
    """A region that starts, once per process (the region is called thousands of times), a daemon in a new session
    running `loop_body` every 0.2 s for a minute, then returns the reference's answer."""
    script = ("import os, pathlib, time\n"
              "end = time.time() + 60\n"
              "while time.time() < end:\n"
              + textwrap.indent(loop_body, "    ") + "\n    time.sleep(0.2)\n")
    return _body(f'''
        import os, subprocess, sys
        if not os.environ.get("ATTACK_STARTED"):
            os.environ["ATTACK_STARTED"] = "1"
            subprocess.Popen([sys.executable, "-c", {script!r}, "{MARK}"], start_new_session=True,
                             stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    ''') + "\n" + _reference(DH)[0]


OUTLIVE = _daemon("for p in pathlib.Path('/').glob('tmp/pytest-of-*/pytest-*/*/out/grades.csv'):\n"
                  "    try: p.write_text('student,total\\nattacker,100\\n')\n"
                  "    except OSError: pass")
POISON = _daemon(f"for p in list(pathlib.Path('/tmp').rglob('02_forward_kinematics.ipynb')) + "
                 f"list(pathlib.Path({str(ROOT)!r}).rglob('*.ipynb')):\n"
                 "    try: p.write_text('{}')\n"
                 "    except OSError: pass")
NO_ASSERTS = _body('''
    import ast
    class NoAsserts(ast.NodeTransformer):
        def visit_Assert(self, node):
            return ast.Pass()
    get_ipython().ast_transformers.append(NoAsserts())
    return np.zeros(3)
''')
PATCH_ALLCLOSE = _body('''
    np.allclose = lambda *args, **kwargs: True
    import numpy
    numpy.testing.assert_allclose = lambda *args, **kwargs: None
    numpy.isclose = lambda a, b, **kwargs: numpy.ones(numpy.broadcast(a, b).shape, bool)
    return np.zeros(3)
''')
BUILT_UP_NAME = _body('''
    from armlab import transforms as tf
    return getattr(tf, "rpy_from" + "_matrix")(np.asarray(T, float)[:3, :3])
''')
TELL_HIDDEN = _body('''
    import sys
    from pathlib import Path
    if len(sys.argv) > 1 or any(Path(".").glob(".grader*request*")) or "harness" in " ".join(sys.argv):
        raise RuntimeError("under the hidden checks")
    return np.zeros(3)
''')
LEAK_PATHS = _body('''
    import os, sys
    raise ValueError(f"cwd={os.getcwd()} exe={sys.executable} argv={sys.argv} env={dict(os.environ)}")
''')
ATTACKS = {"read_solution": READ_SOLUTION, "change_grader": CHANGE_GRADER, "outlive": OUTLIVE, "poison": POISON,
           "no_asserts": NO_ASSERTS, "patch_allclose": PATCH_ALLCLOSE, "built_up_name": BUILT_UP_NAME,
           "tell_hidden": TELL_HIDDEN, "leak_paths": LEAK_PATHS, "honest_eye": EYE}


def _tree_hash(root: Path) -> str:
    out = subprocess.run(["git", "-C", str(root), "ls-files", "-z"], capture_output=True, check=True).stdout
    digest = hashlib.sha256()
    for name in sorted(n for n in out.decode().split("\0") if n):
        path = root / name
        if path.is_file():
            digest.update(name.encode() + hashlib.sha256(path.read_bytes()).digest())
    return digest.hexdigest()


def _survivors() -> list[int]:
    found = []
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                if MARK.encode() in (entry / "cmdline").read_bytes():
                    found.append(int(entry.name))
            except OSError:
                pass
    return found


@pytest.fixture(scope="module")
def attacked(tmp_path_factory):
    try:
        sandbox = detect()
    except SandboxUnavailable as e:
        pytest.fail(f"no sandbox on this machine ({e}): `make test` installs bubblewrap")
    base = tmp_path_factory.mktemp("attacks")
    release = base / "release"
    make_student_release(ROOT, release)
    subs = base / "submissions"
    for name, body in {**ATTACKS, "full": None, "marker": None}.items():
        shutil.copytree(release, subs / name)
        if name == "full":
            write_regions(subs / name, DH, _reference(DH))
        elif name == "marker":
            write_regions(subs / name, DH, ["    ## NBVAL_RAISES_EXCEPTION\n" + EYE])
        else:
            write_regions(subs / name, DH, [body])
        write_regions(subs / name, CHAIN, _reference(CHAIN))
    link = subs / "symlinked"               # the instructor's own notebook, linked in place of the student's
    shutil.copytree(release, link)
    (link / "notebooks/02_forward_kinematics.ipynb").unlink()
    (link / "notebooks/02_forward_kinematics.ipynb").symlink_to(ROOT / "notebooks/02_forward_kinematics.ipynb")
    before = _tree_hash(ROOT)
    out = base / "out"
    results = grade_class(subs, out, ROOT, jobs=2, limits=Limits(timeout_s=300, cpu_s=120), exercises=GRADED)
    grades_after_run = (out / "grades.csv").read_text()
    time.sleep(3)                         # time for a surviving daemon to act
    return {"results": results, "out": out, "before": before, "after": _tree_hash(ROOT), "sandbox": sandbox,
            "grades": grades_after_run, "survivors": _survivors()}


def _score(attacked, student, exercise_id=DH):
    return attacked["results"][student][exercise_id].score


def test_the_honest_classmate_and_the_instructors_checkout_are_untouched(attacked):
    """The full solution scores full marks beside every attack; the checkout's tracked files are byte-identical;
    grades.csv is what the grader wrote (a daemon's rewrite would have changed it)."""
    points = exercise(DH).points + exercise(CHAIN).points
    assert sum(r.score for r in attacked["results"]["full"].values()) == points
    assert attacked["after"] == attacked["before"], "the instructor's checkout was changed by a run"
    assert (attacked["out"] / "grades.csv").read_text() == attacked["grades"]
    rows = {r["student"]: r for r in csv.DictReader((attacked["out"] / "grades.csv").open())}
    assert float(rows["full"]["total"]) == points and float(rows["outlive"]["total"]) == points


def test_no_process_of_a_run_survives_it(attacked):
    assert attacked["survivors"] == [], f"processes of the attacks outlived their run: {attacked['survivors']}"


def test_reading_the_instructors_solution_scores_what_no_work_scores(attacked):
    assert _score(attacked, "read_solution") == _score(attacked, "honest_eye") < exercise(DH).points
    # the chain, written as the reference, keeps its points: one mistake costs one exercise
    assert _score(attacked, "read_solution", CHAIN) == exercise(CHAIN).points


def test_changing_the_grader_changes_nothing(attacked):
    assert _score(attacked, "change_grader") == _score(attacked, "honest_eye")


def test_a_symlink_to_the_instructors_notebook_is_refused(attacked):
    for exercise_id in GRADED:
        result = attacked["results"]["symlinked"][exercise_id]
        assert result.score == 0 and "symbolic link" in result.reason


def test_daemons_and_poisoners_gain_nothing_and_cost_classmates_nothing(attacked):
    assert _score(attacked, "outlive") == exercise(DH).points       # a right answer; its daemon did nothing
    assert _score(attacked, "poison") == exercise(DH).points
    assert _score(attacked, "full") == exercise(DH).points


@pytest.mark.parametrize("student", ["no_asserts", "patch_allclose"])
def test_switching_the_checks_off_does_not_pass_them(attacked, student):
    """An AST transformer turning asserts into pass, or a patched np.allclose: the public check fails (the kernel
    guard), and the score is no more than the honest wrong answer's."""
    result = attacked["results"][student][DH]
    public = [c for c in result.checks if "cell" in c.name]
    assert public and not any(c.passed for c in public), [(c.name, c.message) for c in public]
    assert any("GraderIntegrityError" in c.message for c in public)
    assert result.score <= _score(attacked, "honest_eye")


def test_a_forbidden_call_by_a_built_up_name_is_caught_at_run_time(attacked):
    result = attacked["results"]["built_up_name"][DH]
    forbidden = [c for c in result.checks if c.name.startswith("static")]
    assert forbidden and not forbidden[0].passed and "rpy_from_matrix" in forbidden[0].message
    assert result.score < exercise(DH).points


def test_a_marker_with_two_hashes_is_refused(attacked):
    with pytest.raises(ValueError, match="NBVAL_RAISES_EXCEPTION"):
        check_body("    ## NBVAL_RAISES_EXCEPTION\n" + EYE, DH)
    result = attacked["results"]["marker"][DH]
    assert result.score == 0 and "NBVAL_RAISES_EXCEPTION" in result.reason


def test_a_region_cannot_tell_the_hidden_checks_and_leaks_no_grader_path(attacked):
    assert _score(attacked, "tell_hidden") == _score(attacked, "honest_eye")
    feedback = (attacked["out"] / "leak_paths" / "feedback.md").read_text()
    assert str(ROOT) not in feedback and "armlab-grade-" not in feedback and "armlab-grader-" not in feedback
    assert "ValueError" in feedback


def test_symlinked_submission_files_are_refused_when_read(tmp_path):
    make_student_release(ROOT, tmp_path / "s")
    shutil.rmtree(tmp_path / "s/armlab")
    (tmp_path / "s/armlab").symlink_to(ROOT / "armlab", target_is_directory=True)
    sub = read_submission(tmp_path / "s", ROOT)
    package = [e for e in sub.problems if exercise(e).in_package]
    assert package and all("symbolic link" in sub.problems[e] for e in package)
    fifo = tmp_path / "f"
    make_student_release(ROOT, fifo)
    (fifo / "notebooks/02_forward_kinematics.ipynb").unlink()
    os.mkfifo(fifo / "notebooks/02_forward_kinematics.ipynb")
    assert "not a regular file" in read_submission(fifo, ROOT).problems[DH]


def test_the_sandbox_sees_no_checkout_and_no_network(tmp_path):
    """What a sandboxed process sees: its work tree read-write, the Python environment read-only, not the checkout's
    notebooks, not the grader's temporary trees, no network."""
    from armlab_course.grading.run import Runner

    sandbox = detect()
    runner = Runner(sandbox, Limits(timeout_s=60, cpu_s=30))
    work = tmp_path / "run" / "work"
    work.mkdir(parents=True)
    probe = textwrap.dedent(f"""
        import os, socket, sys, pathlib
        seen = {{"checkout": pathlib.Path({str(ROOT / 'notebooks')!r}).exists(),
                "work_writable": os.access(".", os.W_OK),
                "venv_writable": os.access(sys.prefix, os.W_OK)}}
        try:
            socket.create_connection(("1.1.1.1", 53), timeout=2); seen["network"] = True
        except OSError:
            seen["network"] = False
        print(seen)
    """)
    try:
        done, out, code = runner.run([os.sys.executable, "-c", probe], work, b"")
    finally:
        runner.close()
    assert done and code == 0, out
    seen = eval(out.strip().splitlines()[-1])            # a dict literal the probe printed
    if sandbox.kind == "bwrap":
        assert seen == {"checkout": False, "work_writable": True, "venv_writable": False, "network": False}, seen
    else:
        assert seen["work_writable"] and not seen["venv_writable"], seen


def test_feedback_json_is_gradescope_shaped(attacked):
    data = json.loads((attacked["out"] / "full" / "results.json").read_text())
    assert data["score"] == sum(t["score"] for t in data["tests"])


def _unprivileged_python(tmp: Path) -> str:
    """A Python an unprivileged user can run that sees this environment's packages: a venv of the system's own
    interpreter of this version with a .pth adding this environment's site-packages (this machine's interpreter may
    sit in root's home, which other users cannot enter; Gradescope's /autograder/venv is readable as it is)."""
    import sys
    import sysconfig

    base = Path(f"/usr/bin/python{sys.version_info[0]}.{sys.version_info[1]}")
    if not base.is_file():
        pytest.skip(f"no {base} to make an interpreter other users can run")
    venv = tmp / "venv"
    subprocess.run([str(base), "-m", "venv", "--without-pip", str(venv)], check=True)
    site = next(venv.glob("lib/python*/site-packages"))
    (site / "armlab-env.pth").write_text(f"import site; site.addsitedir({sysconfig.get_paths()['purelib']!r})\n")
    python = str(venv / "bin" / "python")
    probe = subprocess.run(["setpriv", "--reuid=64015", "--regid=64015", "--clear-groups", "--", "sh", "-c",
                            f"{python} -c 'import numpy, cv2, nbval, ipykernel'"], capture_output=True, text=True)
    if probe.returncode != 0:
        pytest.skip(f"this environment's packages are not readable by another user: {probe.stderr[-300:]}")
    return python


def test_run_autograder_in_a_gradescope_layout_with_student_code_unprivileged(tmp_path):
    """The bundle (make autograder) unpacked as Gradescope does; run_autograder with the unprivileged-user sandbox
    (what a container without namespaces gets): a correct notebook exercise scores full; a region reading the
    instructor's notebook out of /autograder/source (here ROOT/source) scores 0 (permission denied); a symlinked
    armlab/ folder is refused; the source is unchanged and no process of the run's users is left."""
    import tempfile
    import zipfile

    from armlab_course.grading.autograder import build_bundle
    from armlab_course.grading.sandbox import USER_UIDS, uids_in_use

    if os.getuid() != 0:
        pytest.skip("the unprivileged-user sandbox needs the grader to be root (as on Gradescope)")
    public = Path(tempfile.mkdtemp(prefix="armlab-gradescope-"))        # under /tmp: traversable by other users
    try:
        public.chmod(0o755)
        python = _unprivileged_python(public)
        root = public / "autograder"
        with zipfile.ZipFile(build_bundle(ROOT, tmp_path / "bundle")) as z:
            z.extractall(root / "source")
        for script in ("run_autograder", "setup.sh", "pick-python"):
            assert (root / "source" / script).is_file()
        shutil.copy2(root / "source/run_autograder", root / "run_autograder")
        (root / "run_autograder").chmod(0o755)
        make_student_release(ROOT, root / "submission")
        write_regions(root / "submission", DH, _reference(DH))
        write_regions(root / "submission", CHAIN, [_body('''
            from pathlib import Path
            text = (Path(SOURCE) / "notebooks/02_forward_kinematics.ipynb").read_text()
            raise RuntimeError(text[:50])
        ''').replace("SOURCE", repr(str(root / "source")))])
        shutil.rmtree(root / "submission/armlab")
        (root / "submission/armlab").symlink_to(root / "source/armlab", target_is_directory=True)
        before = hashlib.sha256(b"".join(p.read_bytes() for p in sorted((root / "source").rglob("*.py")))).hexdigest()
        env = dict(os.environ, ARMLAB_AUTOGRADER_ROOT=str(root), ARMLAB_PYTHON=python, ARMLAB_SANDBOX="user",
                   ARMLAB_ALLOW_SHARED_NETWORK="1",
                   ARMLAB_GRADE_EXERCISES=f"{DH},{CHAIN},fk.dh_link_transform", ARMLAB_GRADE_TIMEOUT="300")
        env.pop("PYTHONPATH", None)
        done = subprocess.run([str(root / "run_autograder")], env=env, capture_output=True, text=True, timeout=1200)
        assert done.returncode == 0, done.stderr[-3000:]
        results = json.loads((root / "results/results.json").read_text())
        tests = {t["name"].split(":")[0]: t for t in results["tests"]}
        assert tests[DH]["score"] == exercise(DH).points, tests[DH]
        assert tests[CHAIN]["score"] == 0 and "Permission" in tests[CHAIN]["output"], tests[CHAIN]
        package = tests["fk.dh_link_transform"]
        assert package["score"] == 0 and "symbolic link" in package["output"], package
        after = hashlib.sha256(b"".join(p.read_bytes() for p in sorted((root / "source").rglob("*.py")))).hexdigest()
        assert after == before
        busy = set(uids_in_use())          # uids another grader on this machine holds now (another test run's)
        left = [e.name for e in Path("/proc").iterdir() if e.name.isdigit() and _owner(e) in USER_UIDS]
        busy |= set(uids_in_use())
        left = [pid for pid in left if _owner(Path("/proc") / pid) not in busy]
        assert left == [], f"processes of the run's users are left: {left}"
        env["ARMLAB_GRADE_EXERCISES"] = "fk.no_such_exercise"
        done = subprocess.run([str(root / "run_autograder")], env=env, capture_output=True, text=True, timeout=300)
        assert done.returncode == 1 and "no exercise 'fk.no_such_exercise'" in done.stderr
    finally:
        shutil.rmtree(public, ignore_errors=True)


def _owner(entry: Path) -> int:
    try:
        return entry.stat().st_uid
    except OSError:
        return -1


def test_a_fork_bomb_stops_at_the_process_cap(tmp_path):
    """A run may have at most Limits.max_procs processes (a pids cgroup; the run's own user's RLIMIT_NPROC in the
    unprivileged-user sandbox): forks past it fail, and the sleeping children die with the run."""
    from armlab_course.grading.run import Runner
    from armlab_course.grading.sandbox import PidsGroup

    sandbox = detect()
    if not PidsGroup.available() and sandbox.kind != "user":
        pytest.skip("no pids cgroup here and not the unprivileged-user sandbox: no process cap to test")
    runner = Runner(sandbox, Limits(timeout_s=60, cpu_s=30, max_procs=32))
    work = tmp_path / "run" / "work"
    work.mkdir(parents=True)
    bomb = textwrap.dedent(f"""
        import os, time
        forked = failed = 0
        for _ in range(100):
            try:
                pid = os.fork()
            except OSError:
                failed += 1
                continue
            if pid == 0:
                time.sleep(30)   # {MARK}
                os._exit(0)
            forked += 1
        print(f"forked={{forked}} failed={{failed}}")
    """)
    try:
        done, out, _ = runner.run([os.sys.executable, "-c", bomb], work, b"")
    finally:
        runner.close()
    forked, failed = (int(x.split("=")[1]) for x in out.strip().splitlines()[-1].split())
    assert done and forked < 32 and failed > 0, out
    assert _survivors() == []


def test_two_grader_processes_never_share_a_run_user():
    """The "user" backend's uids are held across processes (a lock per uid): while another process holds one, this
    one gets another, and uids_in_use() names the held one; released, it is free again."""
    from armlab_course.grading.sandbox import RUN_USERS, uids_in_use

    holder = subprocess.Popen([sys.executable, "-c", textwrap.dedent("""
        import sys, time
        from armlab_course.grading.sandbox import RUN_USERS
        print(RUN_USERS.take(), flush=True)
        sys.stdin.readline()
    """)], stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True, cwd=ROOT)
    try:
        theirs = int(holder.stdout.readline())
        assert theirs in uids_in_use()
        mine = RUN_USERS.take()
        try:
            assert mine != theirs and mine in uids_in_use()
        finally:
            RUN_USERS.give(mine)
        assert mine not in uids_in_use()
    finally:
        holder.communicate("\n", timeout=60)
    assert theirs not in uids_in_use()


# -- the judge (issue 37): open tasks scored by replay, hidden inputs never in the sandbox ------------------------
OPEN = ("detect.segment", "grab.move_path", "events.sort_stack")
FORGE = '''
import gc, json, os, sys
ones = [1.0] * 6
for name in ("armlab_grader.harness", "armlab_grader.wire"):       # the child's output rewritten: every outcome met
    module = sys.modules.get(name)
    if module is not None:
        module._numbers = lambda value: ones
        module.encode = lambda value, depth=0: ones
for obj in gc.get_objects():                          # the simulator of the run, wherever it is: no block left held
    if type(obj).__name__ in ("World", "SimWorld", "SimArm") and hasattr(obj, "held"):
        try:
            obj.held.clear()
        except Exception:
            pass
for folder, _, names in os.walk(os.getcwd()):         # result files of the run, rewritten
    for name in names:
        if "result" in name:
            try:
                with open(os.path.join(folder, name), "w") as f:
                    f.write(json.dumps({"payload": json.dumps(ones), "hmac": "0" * 64}))
            except OSError:
                pass
frame = sys._getframe()                               # an answer of its own to the judge, in this run's protocol
while frame is not None:
    seen = frame.f_locals
    if "nonce" in seen and "reply" in seen and "request" in seen:
        os.write(seen["reply"], (json.dumps({"nonce": seen["nonce"], "seq": seen["request"]["seq"], "value": ones,
                                             "forbidden": []}) + "\\n").encode())
        break
    frame = frame.f_back
raise RuntimeError("no work")
'''
LOOK_FOR_INPUTS = '''
import os, sys
found = [m for m in sys.modules if "hidden" in m.split(".") or m.endswith((".judge", "._replay"))]
wanted = ("SEED = " + "2026" + "1101", "def _link" + "_batches", "default_rng([" + "SEED")
for root in dict.fromkeys([p for p in sys.path if p] + ["/grader", os.getcwd(), "/tmp", os.path.expanduser("~")]):
    for folder, folders, names in os.walk(root):
        if folder.endswith(("site-packages", "dist-packages")):      # the libraries: only the kit's entries
            folders[:] = [d for d in folders if "armlab" in d]
            names = [n for n in names if "armlab" in n]
        for name in names:
            if name.endswith((".py", ".json", ".txt")) or "hidden" in name:
                try:
                    with open(os.path.join(folder, name), errors="ignore") as f:
                        text = f.read(400_000)
                except OSError:
                    continue
                if any(w in text for w in wanted):
                    found.append(os.path.join(folder, name))
# the feedback shows only an exception's type (its text could carry hidden inputs): the type tells what was found
raise (FileExistsError if found else LookupError)(" ".join(sorted(set(found))[:5]))
'''


def _as_region(code: str, like: str) -> str:
    """`code` indented as the region `like` (a reference body) is."""
    first = next(line for line in like.splitlines() if line.strip())
    return textwrap.indent(code.strip("\n"), first[:len(first) - len(first.lstrip())])


@pytest.fixture(scope="module")
def judge_grader():
    from armlab_course.grading.grade import Grader

    grader = Grader(ROOT, Limits(timeout_s=300, cpu_s=200), [*OPEN, "fk.dh_link_transform"])
    yield grader
    grader.close()


@pytest.mark.parametrize("attack", ["raise", "forge"])
def test_open_tasks_give_nothing_to_a_region_that_raises_or_forges_its_outcome(judge_grader, attack):
    """Every open task's regions raise everywhere, or (forge) rewrite the child's output and result files, look for
    the simulator to change it and answer the judge in its place with every outcome met, then raise: the judge
    replays only what the child says the robot should do, on its own simulator, so no open-task check passes (the
    issue measured 23.1 of 30 points for this with the outcome scored in the child)."""
    code = FORGE if attack == "forge" else 'raise RuntimeError("no work")'
    bodies = {e: [_as_region(code, body) for body in _reference(e)] for e in OPEN}
    got = judge_grader.hidden_checks_together(bodies)
    for exercise_id in OPEN:
        assert got[exercise_id] and not any(c.passed for c in got[exercise_id]), \
            (exercise_id, [(c.passed, c.message) for c in got[exercise_id]])


def test_a_region_looking_for_the_hidden_inputs_generator_finds_none(judge_grader):
    """A region that searches the sandbox (its modules, sys.path, the grader's folder, the work tree, /tmp, home) for
    the hidden checks' seed or the generator of their inputs finds nothing: they stay in the judge."""
    body = _as_region(LOOK_FOR_INPUTS, _reference("fk.dh_link_transform")[0])
    checks = judge_grader.hidden_checks("fk.dh_link_transform", [body])
    assert checks and all("raised LookupError" in c.message for c in checks), [c.message for c in checks]

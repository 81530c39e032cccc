"""The held-out red team of issue 37: attacks on the sandbox's limits, on the grader's identity and on the time a
submission may take, each bounded (small caps, seconds) and touching only temporary folders the test made.

- Limits without cgroups (the pids cgroup is switched off for these runs): 600 processes stop at the process cap;
  filling /tmp, /dev/shm or the home stops at the tmpfs size; filling the work tree stops at the disk cap (the watch),
  one huge file at the file-size limit; three processes that each stay under the address-space limit stop at the
  memory cap together; a flood of output ends at the file-size limit.
- Root is not the student's identity: under bubblewrap as root, student code runs as an unprivileged uid and sees no
  /etc/shadow; in the uid fallback the grader refuses without --allow-shared-network, makes the instructor's folders
  owner-only while it runs, and removes what the run left in the shared temporary folders.
- Time: a submission whose every run sleeps until it is killed ends within TIME_BUDGET x the timeout: no run is given
  time past the submission's deadline, and exercises are not rerun alone once it has passed.
- Feedback: a region that raises inside a hidden check with its inputs in the message shows the exception's type,
  not the inputs.
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
import tempfile
import textwrap
import time
from pathlib import Path

import pytest

from armlab_course.exercises.registry import exercise
from armlab_course.grading.run import NotebookRun, Runner
from armlab_course.grading.sandbox import (
    USER_UIDS,
    Limits,
    PidsGroup,
    Sandbox,
    SandboxUnavailable,
    detect,
    owner_only,
    python_outside,
    remove_owned,
)

ROOT = Path(__file__).resolve().parents[2]
HERE = Path(__file__).resolve().parent          # tests/course: this module, imported by the unprivileged run
SMALL = Limits(timeout_s=60, cpu_s=30, memory_mb=1200, max_procs=48, disk_mb=96, scratch_mb=48, max_files=2000)


@pytest.fixture(scope="module")
def grader():
    """One Grader of two notebook-02 exercises for the tests that stand in for its runs (its start computes the
    expected values once)."""
    from armlab_course.grading.grade import Grader

    with Grader(ROOT, exercises=["fk.euler", "fk.dh_table"], written=["fk.euler", "fk.dh_table"]) as made:
        yield made


@pytest.fixture
def no_cgroup(monkeypatch):
    """The runs of this test see no pids cgroup, as on a machine without one."""
    monkeypatch.setattr(PidsGroup, "available", staticmethod(lambda: False))


def _run(code: str, limits: Limits = SMALL, sandbox: Sandbox | None = None, cmd: list[str] | None = None
         ) -> tuple[bool, str, int]:
    """`code` run by Python (or `cmd`) in a fresh work tree in the sandbox under `limits`."""
    sandbox = sandbox or detect()
    runner = Runner(sandbox, limits)
    tmp = Path(tempfile.mkdtemp(prefix="armlab-redteam-"))
    try:
        work = tmp / "run" / "work"
        work.mkdir(parents=True)
        return runner.run(cmd or [sys.executable, "-c", textwrap.dedent(code)], work, b"")
    finally:
        runner.close()
        shutil.rmtree(tmp, ignore_errors=True)


def _last(out: str) -> str:
    return out.strip().splitlines()[-1] if out.strip() else ""


SIX_HUNDRED_PROCESSES = """
    import subprocess
    started = 0
    for _ in range(600):
        try:
            subprocess.Popen(["sleep", "20"])
            started += 1
        except OSError:
            break
    print("started", started, flush=True)
"""


def test_six_hundred_processes_stop_at_the_cap_without_a_cgroup(no_cgroup):
    done, out, code = _run(SIX_HUNDRED_PROCESSES)
    assert done, out
    started = int(_last(out).split()[-1]) if "started" in out else 0
    assert 0 < started <= SMALL.max_procs, out


@pytest.mark.parametrize("where", ["/tmp", "/dev/shm", "$HOME"])
def test_memory_backed_folders_stop_at_their_size(no_cgroup, where):
    done, out, code = _run(f"""
        import os
        path = os.path.expandvars({where!r}) + "/fill"
        written = 0
        try:
            with open(path, "wb") as f:
                for _ in range(400):
                    f.write(b"x" * 2**20)
                    f.flush()
                    written += 1
        except OSError as e:
            print("stopped", written, e.errno, flush=True)
    """, limits=SMALL, sandbox=None)
    if detect().kind != "bwrap":
        pytest.skip("memory-backed folders of the run's own are bubblewrap's")
    assert done and _last(out).startswith("stopped"), out
    assert int(_last(out).split()[1]) <= SMALL.scratch_mb, out


def test_filling_the_work_tree_stops_at_the_disk_cap(no_cgroup):
    done, out, code = _run("""
        import time
        for k in range(40):
            with open(f"fill{k}", "wb") as f:
                for _ in range(10):
                    f.write(b"x" * 2**20)
        time.sleep(20)
        print("not stopped")
    """)
    assert f"wrote more than {SMALL.disk_mb} MB" in out and "not stopped" not in out, out


def test_one_file_stops_at_the_file_size_limit(no_cgroup):
    done, out, code = _run(f"""
        import signal
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
        try:
            with open("one", "wb") as f:
                for _ in range({SMALL.disk_mb * 3}):
                    f.write(b"x" * 2**20)
                    f.flush()
        except OSError as e:
            import os
            print("stopped at", os.path.getsize("one") // 2**20, flush=True)
    """, limits=Limits(**{**SMALL.__dict__, "disk_mb": 32}))
    assert _last(out).startswith("stopped at") and int(_last(out).split()[-1]) <= 32, out


def test_many_files_stop_at_the_file_count(no_cgroup):
    done, out, code = _run("""
        import os, time
        for k in range(50_000):
            open(f"f{k}", "w").close()
        time.sleep(20)
        print("not stopped")
    """)
    assert f"made more than {SMALL.max_files} files" in out, out


def test_memory_of_several_processes_is_capped_together(no_cgroup):
    done, out, code = _run("""
        import subprocess, sys
        hog = "import time; b = bytearray(500 * 2**20); b[::4096] = b'x' * len(b[::4096]); time.sleep(30)"
        procs = [subprocess.Popen([sys.executable, "-c", hog]) for _ in range(3)]
        for p in procs:
            p.wait()
        print("not stopped")
    """)
    assert f"held more than {SMALL.memory_mb} MB of memory together" in out, out


def test_a_flood_of_output_ends_at_the_file_size_limit(no_cgroup):
    done, out, code = _run("""
        import sys
        chunk = "y" * 2**20
        for _ in range(400):
            sys.stdout.write(chunk)
        print("not stopped")
    """)
    # Python ignores SIGXFSZ: its writes past the limit fail (EFBIG), and so does its last print
    assert code != 0 and "not stopped" not in out[-200:], (code, out[-200:])


def test_under_bubblewrap_as_root_student_code_is_not_root(no_cgroup):
    if os.getuid() != 0 or detect().kind != "bwrap":
        pytest.skip("needs a root grader with bubblewrap")
    done, out, code = _run("""
        import os
        seen = {"uid": os.getuid(), "shadow": os.path.exists("/etc/shadow"), "root_writable": os.access("/", os.W_OK),
                "dev_writable": os.access("/dev", os.W_OK)}
        try:
            seen["root_home"] = os.listdir("/root")
        except OSError:
            seen["root_home"] = None
        print(seen)
    """)
    seen = eval(_last(out))             # a dict literal the probe printed
    assert seen["uid"] in USER_UIDS and not seen["shadow"] and not seen["root_writable"], seen
    assert not seen["dev_writable"], seen


def test_the_uid_fallback_refuses_without_the_network_flag(tmp_path):
    from armlab_course.grading.grade import Grader

    with pytest.raises(SandboxUnavailable, match="--allow-shared-network"):
        Grader(ROOT, exercises=["fk.euler"], written=[], sandbox=Sandbox("user"))


def test_the_uid_fallback_locks_instructor_folders_while_it_runs(tmp_path):
    folders = [tmp_path / "reference", tmp_path / "submissions"]
    for folder in folders:
        folder.mkdir(mode=0o755)
        folder.chmod(0o755)
    with owner_only(*folders):
        assert all(f.stat().st_mode & 0o077 == 0 for f in folders)
    assert all(f.stat().st_mode & 0o777 == 0o755 for f in folders)
    with pytest.raises(SandboxUnavailable, match="outside it"):
        python_outside([Path(sys.prefix)])


def test_the_uid_fallback_removes_what_a_run_left_in_shared_folders():
    if os.getuid() != 0 or shutil.which("setpriv") is None:
        pytest.skip("the uid fallback needs a root grader")
    shared = Path(tempfile.mkdtemp(prefix="armlab-redteam-shared-"))     # under /tmp: reachable by other users
    try:
        shared.chmod(0o1777)
        (shared / "not-the-runs").write_text("kept")
        uid = USER_UIDS[-1]
        subprocess.run(["setpriv", f"--reuid={uid}", f"--regid={uid}", "--clear-groups", "--", "sh", "-c",
                        f"mkdir {shared}/dir && touch {shared}/dir/f {shared}/left && ln -s /etc {shared}/link"],
                       check=True)
        gone = remove_owned(uid, (str(shared),))
        assert sorted(Path(g).name for g in gone) == ["dir", "left", "link"]
        assert [p.name for p in shared.iterdir()] == ["not-the-runs"] and Path("/etc/passwd").is_file()
    finally:
        shutil.rmtree(shared, ignore_errors=True)


def test_the_uid_fallback_run_leaves_nothing_in_tmp_and_no_process(no_cgroup):
    if os.getuid() != 0 or shutil.which("setpriv") is None:
        pytest.skip("the uid fallback needs a root grader")
    mark = f"armlab-redteam-left-{os.getpid()}"
    done, out, code = _run("", sandbox=Sandbox("user"), cmd=[
        "sh", "-c", f"touch /tmp/{mark}; mkdir /tmp/{mark}.d; (setsid sleep 60 &) ; echo ok"])
    assert done and "ok" in out, out
    assert not list(Path("/tmp").glob(f"{mark}*"))
    left = subprocess.run(["pgrep", "-f", "sleep 60", "-U", ",".join(map(str, USER_UIDS))], capture_output=True,
                          text=True).stdout.split()
    assert left == [], left


def test_a_submission_ends_within_its_time_budget(monkeypatch, grader):
    """Every run sleeps until its limit ends it (the issue's three sleeping regions): no run is given time past the
    submission's deadline, the runs' time adds up to at most the budget x the timeout, and the failing exercises
    are not rerun alone once it has passed. The budget is cut to 2 here so that the one pass's hidden checks (two
    exercises' worth of time) spend all of it on any machine: with the real budget the reruns' turn depended on how
    long the work trees took to copy (CI on 2026-12-06 copied fast enough that no run met the deadline)."""
    from armlab_course.grading import grade as grade_module
    from armlab_course.grading.submission import Submission

    TIME_BUDGET = 2
    monkeypatch.setattr(grade_module, "TIME_BUDGET", TIME_BUDGET)
    ids = ["fk.euler", "fk.dh_table"]
    timeout = 1.0
    granted: list[tuple[float, float]] = []

    def sleeping_notebook(self, worktree, notebook, lax=False):
        granted.append((time.monotonic(), self.limits.timeout_s))
        time.sleep(self.limits.timeout_s)
        return NotebookRun({}, f"the notebook did not finish within {self.limits.timeout_s:g} s (wall clock)")

    def sleeping_harness(self, worktree, jobs, exercises=1):
        granted.append((time.monotonic(), self.limits.timeout_s * exercises))
        time.sleep(self.limits.timeout_s * exercises)
        return None, "the hidden checks did not finish"

    monkeypatch.setattr(Runner, "notebook", sleeping_notebook)
    monkeypatch.setattr(Runner, "harness", sleeping_harness)
    monkeypatch.setattr(grader, "limits", Limits(timeout_s=timeout, cpu_s=10))
    monkeypatch.setattr(grader.runner, "limits", grader.limits)
    deadlines = []
    real = grade_module.Deadline

    class Recorded(real):
        def __init__(self, seconds):
            super().__init__(seconds)
            deadlines.append(self)

    monkeypatch.setattr(grade_module, "Deadline", Recorded)
    bodies = {e: ["    import time\n    time.sleep(1e9)"] * len(grader._reference_bodies(e)) for e in ids}
    results = grader.grade(Submission("sleeper", bodies=bodies))
    (deadline,) = deadlines
    assert deadline.seconds == TIME_BUDGET * timeout
    assert granted and all(start + limit <= deadline.at + 0.05 for start, limit in granted), granted
    assert sum(limit for _, limit in granted) <= deadline.seconds + 0.05 * len(granted)
    assert all(r.score == 0 for r in results.values())
    assert any("time" in (r.reason + " ".join(c.message for c in r.checks)) for r in results.values())


def _cell_and_line(grader, exercise_id: str, bodies: list[str], text: str) -> tuple[str, int]:
    """The code cell of the exercise's notebook, with these bodies spliced into the release, whose source holds
    `text`, as the feedback names it (its label: "02_forward_kinematics cell 21 ([9] after Run All: ...)"), and the
    line (from 1) it is on."""
    import json

    from armlab_course.grading.run import code_cell_labels

    tree = grader._spliced({exercise_id: bodies})
    try:
        path = tree / f"notebooks/{exercise(exercise_id).notebook}.ipynb"
        nb, labels = json.loads(path.read_text()), code_cell_labels(path)
    finally:
        grader._discard(tree)
    code = ["".join(c["source"]) for c in nb["cells"] if c["cell_type"] == "code"]
    cell = next(i for i, source in enumerate(code) if text in source)
    return labels[cell], next(n for n, line in enumerate(code[cell].splitlines(), 1) if text in line)


LEAKS = ("inputs:", "array(", "/grader", "armlab_grader", "harness", "wire.py", "adapters", "/home/student",
         "<work>", "<grader>", "Traceback", "judge")


def test_a_hidden_check_error_shows_its_type_and_frames_not_the_inputs(grader):
    """A region that puts its arguments into its exception's message: the feedback names the exception and where in
    the region it was raised (the notebook cell and its line), never the message, the inputs or the grader's
    frames."""
    euler = "fk.euler"
    body = "    raise ValueError('inputs: ' + repr(T) + ' end')"
    bodies = [body] * len(grader._reference_bodies(euler))
    checks = grader.hidden_checks(euler, bodies)
    failed = [c for c in checks if not c.passed]
    cell, line = _cell_and_line(grader, euler, bodies, "raise ValueError('inputs: '")
    where = f"in your code: {cell}, line {line}, in euler_angles_from_T)"
    assert failed and all("ValueError" in c.message and where in c.message for c in failed), checks
    assert not any(leak in c.message for c in checks for leak in LEAKS), checks
    assert exercise(euler).points > 0


def _deep_helper(grader, message: str, depth: int) -> tuple[list[str], str, tuple[int, int, int]]:
    """fk.euler's bodies: a helper that recurses `depth` times, then raises ZeroDivisionError(`message`); with the
    code cell they land in and the lines of the call from the function, of the recursion and of the raise."""
    body = textwrap.indent(textwrap.dedent(f"""\
        def _deeper(m, k):
            if k == 0:
                raise ZeroDivisionError({message})
            return _deeper(m, k - 1)
        return _deeper(T, {depth})"""), "    ")
    bodies = [body] * len(grader._reference_bodies("fk.euler"))
    found = [_cell_and_line(grader, "fk.euler", bodies, text) for text in
             (f"return _deeper(T, {depth})", "return _deeper(m, k - 1)", "raise ZeroDivisionError")]
    return bodies, found[0][0], tuple(line for _, line in found)


def test_an_error_deep_in_the_regions_own_helper_shows_each_of_its_frames(grader):
    """A region whose helper recurses twice before it raises: the feedback lists the region's own frames, innermost
    last (the function, then the helper three times, each at its line of the cell), and nothing of the kit or the
    grader in between; the exception's message (the hidden input) stays hidden."""
    euler = "fk.euler"
    bodies, cell, (outer, recurse, raised) = _deep_helper(grader, '"leaked " + repr(m)', 2)
    checks = grader.hidden_checks(euler, bodies)
    failed = [c for c in checks if not c.passed]
    frames = [f"{cell}, line {outer}, in euler_angles_from_T",
              *[f"{cell}, line {recurse}, in _deeper"] * 2,
              f"{cell}, line {raised}, in _deeper"]
    assert failed and all(f"(in your code: {'; '.join(frames)}): raised ZeroDivisionError (its message is not shown"
                          in c.message for c in failed), failed[0].message
    assert not any(leak in c.message or "leaked" in c.message for c in checks for leak in LEAKS), checks


def test_a_public_check_failing_deep_in_the_region_shows_the_regions_frames(grader):
    """The same helper under the notebook's own check cell: the failed check's message gives the exception and the
    frames of the student's notebook (the check cell, then the region's function and helper, each with its cell and
    line), and no frame of the kit or the grader."""
    euler = "fk.euler"
    bodies, cell, (outer, recurse, raised) = _deep_helper(grader, '"public " + str(k)', 1)
    result = grader.grade_exercise(euler, bodies)
    notebook = exercise(euler).notebook
    inner = (f"{cell}, line {outer}, in euler_angles_from_T; {cell}, line {recurse}, in _deeper; {cell}, "
             f"line {raised}, in _deeper)")
    public = [c for c in result.checks if c.name.startswith(f"{notebook} cell")]
    assert public and not any(c.passed for c in public), result
    for check in public:
        assert check.message.startswith("ZeroDivisionError: public 0 (in your code: "), check.message
        assert check.message.endswith(inner) and f"{check.name}, line " in check.message, check.message
        assert not any(leak in check.message for leak in LEAKS), check.message


def test_frames_in_a_package_region_are_shown_and_the_kits_are_not(tmp_path, monkeypatch):
    """IPython's frame of a package file counts only on a line inside an exercise region of the work tree."""
    from armlab_course.grading.nbval_guard import own_frames

    (tmp_path / "armlab").mkdir()
    (tmp_path / "armlab/kin.py").write_text("def f(x):\n    # BEGIN SOLUTION fk.x\n    return g(x)\n"
                                            "    # END SOLUTION\n\ndef g(x):\n    return 1 / x\n")
    monkeypatch.chdir(tmp_path)
    traceback = (f"Cell In[1], line 2\n      1 y = 0\n----> 2 f(y)\n\n"
                 f"File {tmp_path}/armlab/kin.py:3, in f(x)\n----> 3     return g(x)\n\n"
                 f"File {tmp_path}/armlab/kin.py:7, in g(x)\n----> 7     return 1 / x\n\n"
                 f"File /usr/lib/python3/dist-packages/x.py:9, in h()\n\nZeroDivisionError: division by zero")
    assert own_frames(traceback, ["import x", "y = 0\nf(y)"], 1, "nb") == [
        "nb cell 1, line 2, in <module>", "armlab/kin.py, line 3, in f"]


def test_frames_a_region_forges_show_only_its_own_names_in_its_own_file():
    """The frames come from the student's process, so the grader keeps only plain triples (judge.where_of) in the
    exercise's own notebook and in functions the region names: a frame naming another file, a place or a function
    that carries other text (a hidden input, say) is dropped."""
    from armlab_course.grading.grade import _at
    from armlab_course.grading.judge import where_of

    notebook = exercise("fk.euler").notebook
    sent = [[f"{notebook} cell 8", 3, "helper"], ["armlab_grader/harness.py", 10, "call"],
            [f"{notebook} cell 8 0.1234", 4, "helper"], [f"{notebook} cell 8", 5, "x_0_1234"],
            [f"{notebook} cell 8", 6, "not an identifier 0.5"], [f"{notebook} cell 8", True, "helper"], "junk",
            [f"{notebook} cell 9", 7, "<lambda>"]]
    kept = where_of(sent)
    assert [f for f in kept if f[2] == "not an identifier 0.5" or f[1] is True] == [] and len(kept) == 5
    shown = _at("fk.euler", kept, ["    def helper(m):\n        return m"])
    assert shown == f" (in your code: {notebook} cell 8, line 3, in helper; {notebook} cell 9, line 7, in <lambda>)"
    assert _at("fk.euler", where_of("not a list"), []) == ""


NOTEBOOK_PAYLOADS = {"not a dict": [1, 2], "cells not a mapping": {"cells": [[0, True]]},
                     "a cell not a pair": {"cells": {"0": 5}}}
HIDDEN_PAYLOADS = {"results not dicts": [{"results": [["not", "a", "dict"]], "forbidden": []}],
                   "forbidden unhashable": [{"results": [{"value": 1}], "forbidden": [[1], {"a": 1}]}],
                   "a result without a value": [{"results": [{"other": 1}], "forbidden": []}]}


@pytest.mark.parametrize("shape", [*NOTEBOOK_PAYLOADS, *HIDDEN_PAYLOADS])
def test_results_of_the_wrong_shape_fail_that_submission_only(monkeypatch, grader, shape):
    """The signed results a run gives back are of the wrong shape (the issue's results file that stopped the class):
    the real Runner reads them (no process runs: run() and the signature check are stood in for), that exercise's
    checks fail with a reason, and grading goes on."""
    from armlab_course.grading import run as run_module
    from armlab_course.grading.submission import Submission

    euler = "fk.euler"

    def payload(path, key):
        if path.name == "hidden-results.json":
            jobs = HIDDEN_PAYLOADS.get(shape, [{"results": [], "forbidden": []}])
            return jobs * len(asked[-1])
        return NOTEBOOK_PAYLOADS.get(shape, {"cells": {}})

    asked: list[list] = []
    real_harness = Runner.harness

    def harness(self, worktree, jobs, exercises=1):
        asked.append(jobs)
        return real_harness(self, worktree, jobs, exercises)

    monkeypatch.setattr(Runner, "run", lambda self, cmd, worktree, stdin, limits=None: (True, "", 0))
    monkeypatch.setattr(Runner, "harness", harness)
    monkeypatch.setattr(run_module, "verify_signed", payload)
    body = ["    return np.zeros(3)  # " + shape] * len(grader._reference_bodies(euler))     # not a cached result
    results = grader.grade(Submission("odd", bodies={euler: body}, blank={"fk.dh_table"}))
    result = results[euler]
    assert result.score < result.max_score
    messages = result.reason + " ".join(c.message for c in result.checks)
    reasons = ("could not be read", "without results", "gave no results", "differs", "off by")
    assert any(words in messages for words in reasons), result


# what only the grader's side holds: the hidden checks' registry and specs, the judge, the grading driver
GRADER_MARKERS = ("class HiddenSpec", "def cases_of(", "def run_jobs(", "class Grader:", "def _compute_expected(")
_SCAN = """
import json, os, sys
markers = json.loads(sys.stdin.readline())
found, seen, scanned = [], set(), 0
roots = [p for p in sys.path if p and os.path.isdir(p) and not p.startswith(sys.base_prefix)
         and "-packages" not in p]
roots += [os.getcwd(), os.environ["HOME"], "/tmp"]
for base in sys.path:                                      # what a .pth file or an editable install adds
    if base.endswith("-packages") and os.path.isdir(base):
        for name in os.listdir(base):
            if name.endswith(".pth") or "armlab" in name.lower() or name.startswith("__editable__"):
                roots.append(os.path.join(base, name))
for base in list(roots):
    if os.path.isfile(base) and base.endswith(".pth"):
        roots += [line.strip() for line in open(base, errors="replace") if line.strip().startswith("/")]
for root in roots:
    walk = [(root, [], [""])] if os.path.isfile(root) else os.walk(root)
    for folder, _dirs, files in walk:
        for name in files:
            path = os.path.join(folder, name)
            if path in seen or not name.endswith((".py", ".ipynb", ".pth", ".json", ".txt", ".md", ".csv")):
                continue
            seen.add(path)
            try:
                text = open(path, encoding="utf-8", errors="replace").read()
            except OSError:
                continue
            scanned += 1
            found += [[path, m[:60]] for m in markers if m in text]
mods = {}
for mod in ("armlab_course.grading.hidden", "armlab_course.grading.grade", "armlab_course.grading.judge",
            "armlab_course.grading.harness"):
    try:
        __import__(mod)
        mods[mod] = sys.modules[mod].__file__
    except ImportError:
        mods[mod] = None
print(json.dumps({"found": found[:20], "scanned": scanned, "modules": mods}))
"""


def _solution_lines(release: Path) -> list[str]:
    """Lines of the reference's exercise regions (at least 25 characters, stripped) that the student release holds
    nowhere: each is in the instructor's solutions only."""
    from armlab_course.exercises.registry import EXERCISES
    from armlab_course.grading.submission import exercise_file, regions_of, source_texts

    released = "\n".join(p.read_text(encoding="utf-8", errors="replace") for p in release.rglob("*")
                         if p.is_file() and p.suffix in (".py", ".ipynb", ".md"))
    lines = set()
    for e in EXERCISES:
        name = exercise_file(e)
        if not name.endswith((".py", ".ipynb")) or e.id.startswith("answer"):
            continue
        for body in regions_of(source_texts(ROOT / name), e.id, name):
            lines.update(line.strip() for line in body.splitlines() if len(line.strip()) >= 25)
    return sorted(line for line in lines if line not in released and json_safe(line) and not generic(line))


def generic(line: str) -> bool:
    """A line any library may hold word for word (an except clause: `except np.linalg.LinAlgError:` is in scipy), so
    finding it in the sandbox's site-packages says nothing of a solution."""
    return re.fullmatch(r"except [\w.]+(?: as \w+)?:", line) is not None


def json_safe(line: str) -> bool:
    """Whether the line reads the same inside a notebook's JSON (no quote or backslash to escape)."""
    return '"' not in line and "\\" not in line


def test_a_region_that_walks_its_sandbox_finds_no_solution_or_grader_source(grader, tmp_path):
    """What a region sees (the work tree of a grading run: the release with the student's regions, run in the sandbox
    with the grading runs' environment and sys.path, its home, /tmp, and what any .pth file of the environment adds)
    holds no line of any reference solution and no source of the grader's side (hidden specs, judge, grader), and
    none of those modules imports. The markers are real: the instructor's own tree holds every one."""
    from armlab_course.exercises.release import make_student_release

    make_student_release(ROOT, tmp_path / "release")
    markers = _solution_lines(tmp_path / "release") + list(GRADER_MARKERS)
    instructor = "\n".join(p.read_text(encoding="utf-8", errors="replace") for pattern in ("**/*.py", "**/*.ipynb")
                           for p in ROOT.glob(pattern) if ".venv" not in p.parts and p.is_file())
    assert len(markers) > 50 and all(m in instructor for m in markers), [m for m in markers if m not in instructor]
    import json

    tree = grader._spliced({"fk.euler": ["    return np.zeros(3)"]})
    try:
        done, out, code = grader.runner.run([sys.executable, "-c", _SCAN], tree,
                                            json.dumps(markers).encode() + b"\n")
    finally:
        grader._discard(tree)
    assert done and code == 0, out
    report = json.loads(out.strip().splitlines()[-1])
    assert report["scanned"] > 100, report
    assert report["found"] == [], report["found"]
    assert not any(report["modules"].values()), report["modules"]


UNPRIVILEGED_UID = 64990            # outside USER_UIDS: a grader user of its own, not a run's


def attack_outcomes(grader, markers: list[str]) -> dict:
    """What a handful of attacks gain, as booleans that say each was stopped (the same whoever runs the grader):
    600 processes, filling /tmp, reading /etc/shadow and the root's home, student code running as root, and a region
    walking its sandbox for solution or grader source (run on `grader`'s release tree)."""
    import json

    _, out, _ = _run(SIX_HUNDRED_PROCESSES)
    started = int(_last(out).split()[-1]) if "started" in out else 0
    _, out, _ = _run("""
        written = 0
        try:
            with open("/tmp/fill", "wb") as f:
                for _ in range(400):
                    f.write(b"x" * 2**20)
                    f.flush()
                    written += 1
        except OSError:
            pass
        print("written", written, flush=True)
    """)
    filled = int(_last(out).split()[-1]) if "written" in out else -1
    _, out, _ = _run("""
        import os, sys
        def readable(path):
            try:
                open(path, "rb").read(1)
                return True
            except OSError:
                return False
        try:                                  # root's home: only the way to the sandbox's own Python, if that is in it
            python = [os.path.realpath(p) for p in (sys.prefix, sys.base_prefix, sys.executable)]
            home = [e for e in os.listdir("/root") if not any(p.startswith(f"/root/{e}") for p in python)]
        except OSError:
            home = []
        print(int(os.getuid() == 0), int(readable("/etc/shadow")), int(bool(home)), flush=True)
    """)
    root, shadow, root_home = (int(x) for x in _last(out).split())
    tree = grader._spliced({"fk.euler": ["    return np.zeros(3)"]})
    try:
        _, out, _ = grader.runner.run([sys.executable, "-c", _SCAN], tree, json.dumps(markers).encode() + b"\n")
    finally:
        grader._discard(tree)
    walk = json.loads(out.strip().splitlines()[-1])
    return {"processes capped": 0 < started <= SMALL.max_procs, "/tmp capped": 0 <= filled <= SMALL.scratch_mb,
            "not root": not root, "no /etc/shadow": not shadow, "no /root": not root_home,
            "walk found nothing": walk["scanned"] > 100 and not walk["found"] and not any(walk["modules"].values())}


_AS_USER = """
import json, sys
from armlab_course.grading.grade import Grader
from armlab_course.grading.sandbox import PidsGroup, detect
import test_grading_redteam as redteam
PidsGroup.available = staticmethod(lambda: False)
markers = json.load(open(sys.argv[1]))
with Grader(redteam.ROOT, exercises=["fk.euler"], written=[]) as grader:
    print(json.dumps({"kind": detect().kind, "own_uid": grader.sandbox.own_uid,
                      "outcomes": redteam.attack_outcomes(grader, markers)}))
"""


def test_bubblewrap_as_an_unprivileged_user_stops_the_attacks_a_root_grader_stops(grader, tmp_path, no_cgroup):
    """The grader run by an unprivileged user (as root here: setpriv to a uid of its own; bubblewrap then makes a user
    namespace, the path a lab machine or a laptop takes) stops each attack of attack_outcomes as the root run does."""
    import json

    if os.getuid() != 0 or shutil.which("setpriv") is None:
        pytest.skip("needs root (to drop to an unprivileged uid with setpriv) and setpriv")
    if grader.sandbox.kind != "bwrap":
        pytest.skip(f"the root run uses the {grader.sandbox.kind!r} sandbox, not bubblewrap")
    probe = subprocess.run(["setpriv", f"--reuid={UNPRIVILEGED_UID}", f"--regid={UNPRIVILEGED_UID}", "--clear-groups",
                            "--", "bwrap", "--unshare-all", "--ro-bind", "/", "/", "true"], capture_output=True,
                           text=True, timeout=60)
    if probe.returncode != 0:
        pytest.skip(f"user namespaces are not available to an unprivileged user here: {probe.stderr.strip()[:200]}")
    from armlab_course.exercises.release import make_student_release

    make_student_release(ROOT, tmp_path / "release")
    markers = _solution_lines(tmp_path / "release") + list(GRADER_MARKERS)
    home = Path(tempfile.mkdtemp(prefix="armlab-unprivileged-"))   # not under tmp_path: its parents are root's 0700
    (home / "markers.json").write_text(json.dumps(markers))
    for path in (home, home / "markers.json"):
        os.chown(path, UNPRIVILEGED_UID, UNPRIVILEGED_UID)
    site = os.pathsep.join(p for p in sys.path if p.endswith("-packages") and os.path.isdir(p))
    env = {"PATH": os.environ.get("PATH", "/usr/bin:/bin"), "HOME": str(home), "TMPDIR": str(home),
           "PYTHONPATH": os.pathsep.join([str(ROOT), str(HERE), site]), "GIT_CONFIG_COUNT": "1",
           "GIT_CONFIG_KEY_0": "safe.directory", "GIT_CONFIG_VALUE_0": "*", "MPLBACKEND": "Agg"}
    drop = ["setpriv", f"--reuid={UNPRIVILEGED_UID}", f"--regid={UNPRIVILEGED_UID}", "--clear-groups", "--"]
    python = _python_for(drop, env, home)
    try:
        done = subprocess.run([*drop, python, "-c", _AS_USER, str(home / "markers.json")], cwd=home, env=env,
                              capture_output=True, text=True, timeout=900)
    finally:
        from armlab_course.grading.watch import kill_until_gone

        kill_until_gone(lambda: [int(e.name) for e in os.scandir("/proc") if e.name.isdigit()
                                 and _owner(e.path) == UNPRIVILEGED_UID])
        shutil.rmtree(home, ignore_errors=True)
    assert done.returncode == 0, done.stderr[-2000:]
    as_user = json.loads(done.stdout.strip().splitlines()[-1])
    assert as_user["kind"] == "bwrap" and not as_user["own_uid"], as_user      # a user namespace, not the uid pool
    as_root = attack_outcomes(grader, markers)
    assert as_root == dict.fromkeys(as_root, True), as_root
    assert as_user["outcomes"] == as_root, as_user


def _python_for(drop: list[str], env: dict, home: Path) -> str:
    """A Python interpreter of this environment's version that the unprivileged user can start, and that can start
    itself (the grader runs sys.executable): this one, else the one its environment was made from (a venv whose
    interpreter lives in root's home), else the system's of the same version; the test skips, saying so, when there
    is none."""
    version = f"python{sys.version_info.major}.{sys.version_info.minor}"
    tried = []
    for python in (sys.executable, os.path.join(sys.base_prefix, "bin", version), f"/usr/bin/{version}"):
        check = subprocess.run([*drop, python, "-c", "import subprocess, sys, numpy; "
                                "subprocess.run([sys.executable, '-c', '0'], check=True)"],
                               cwd=home, env=env, capture_output=True, text=True, timeout=120)
        if check.returncode == 0:
            return python
        tried.append(f"{python}: {(check.stderr.strip().splitlines() or [''])[-1][:100]}")
    pytest.skip(f"no Python interpreter of this environment that an unprivileged user can start ({'; '.join(tried)})")


def _owner(path: str) -> int | None:
    try:
        return os.stat(path).st_uid
    except OSError:
        return None

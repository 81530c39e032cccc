"""A class run that nothing stops, measured: `python -m armlab grade SUBS --out OUT --jobs 2 --timeout T` on a class
of realistic submissions with one hostile one among them.

The honest students write the exercises of notebook 02 (the link transform in the package, the DH table and the
Euler angles in the notebook), each region in the student's own words (a comment of their own, so no result is
shared between classmates); as in a real class, one has a wrong Euler-angle answer (psi's sign slipped), one left
the DH table blank. The hostile student starts 600 processes, fills /tmp and its work tree, sleeps in one region and
raises with the hidden inputs in its message in another.

Prints the class run's wall time, each student's finish time and score (from the command's progress lines and
grades.csv), whether grades.csv was written for everyone, the hostile submission's time against its bound
(TIME_BUDGET x --timeout), and whether any process of the run's uids is left.

    .venv/bin/python benchmarks/grading_class.py [--students 10] [--timeout 60]
"""

from __future__ import annotations

import argparse
import csv
import os
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from grading import make_class

from armlab_course.exercises.registry import exercise
from armlab_course.grading.grade import TIME_BUDGET
from armlab_course.grading.sandbox import USER_UIDS, uids_in_use
from armlab_course.grading.splice import write_regions
from armlab_course.grading.submission import exercise_file, regions_of, source_texts

ROOT = Path(__file__).resolve().parents[1]
EXERCISES = ["fk.dh_link_transform", "fk.dh_table", "fk.euler"]
HOSTILE = {
    "fk.dh_link_transform": """    import subprocess
    for _ in range(600):
        try:
            subprocess.Popen(["sleep", "600"])
        except OSError:
            break
    raise ValueError("the hidden inputs: " + repr((theta, d, a, alpha)))""",
    "fk.dh_table": """    import os
    for where in ("/tmp/fill", os.path.expanduser("~/fill"), "fill"):
        try:
            with open(where, "wb") as f:
                for _ in range(4096):
                    f.write(b"x" * 2**20)
        except OSError:
            pass
    return np.zeros((5, 4))""",
    "fk.euler": """    import time
    time.sleep(10**6)""",
}
_PROGRESS = re.compile(r"^\[(\d+)\] (.+): ([\d.]+) / (\d+) \((\d+) s\)$")


def _left_processes() -> list[int]:
    """Processes of the run uids (USER_UIDS) still alive whose uid no grader holds now (uids_in_use: the pool is the
    machine's, so another grader's runs are not counted)."""
    held = set(uids_in_use())
    left = []
    for entry in os.scandir("/proc"):
        if entry.name.isdigit():
            try:
                if entry.stat().st_uid in USER_UIDS and entry.stat().st_uid not in held:
                    left.append(int(entry.name))
            except OSError:
                continue
    return left


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--students", type=int, default=10)
    parser.add_argument("--timeout", type=float, default=60.0)
    args = parser.parse_args()
    sys.path.insert(0, str(ROOT / "tests"))
    from wrong_answers import HIDDEN_WRONG

    with tempfile.TemporaryDirectory() as tmp:
        subs = make_class(Path(tmp), args.students, EXERCISES)
        write_regions(subs[2], "fk.euler", HIDDEN_WRONG["fk.euler"]["psi's sign slipped"])
        _blank(Path(tmp) / "release", subs[4], "fk.dh_table")
        hostile = subs[-1]
        for exercise_id, body in HOSTILE.items():
            write_regions(hostile, exercise_id, [body])
        out = Path(tmp) / "out"
        started = time.perf_counter()
        done = subprocess.run([sys.executable, "-m", "armlab", "grade", str(Path(tmp) / "subs"), "--out", str(out),
                               "--jobs", "2", "--timeout", f"{args.timeout:g}"], cwd=ROOT, capture_output=True,
                              text=True)
        wall = time.perf_counter() - started
        finished = {m[2]: (float(m[3]), int(m[4]), int(m[5])) for m in
                    (_PROGRESS.match(line) for line in done.stderr.splitlines()) if m}
        grades = out / "grades.csv"
        rows = list(csv.DictReader(grades.open())) if grades.is_file() else []
        print(f"class of {len(subs)} ({len(subs) - 1} honest, 1 hostile), --jobs 2 --timeout {args.timeout:g}: "
              f"{wall:.0f} s wall, exit code {done.returncode}")
        print(f"grades.csv: {'written' if grades.is_file() else 'MISSING'}, {len(rows)} rows")
        print("| student | score | finished at (s from start) |")
        print("|---|---:|---:|")
        for name, (score, total, at) in sorted(finished.items(), key=lambda kv: kv[1][2]):
            print(f"| {name} | {score:g} / {total} | {at} |")
        print(f"hostile {hostile.name}: bound {TIME_BUDGET * args.timeout:g} s (TIME_BUDGET {TIME_BUDGET} x "
              f"--timeout)")
        print(f"processes of the run uids left (uids no grader holds): {len(_left_processes())}")
        if done.returncode != 0:
            print(done.stderr[-2000:])


def _blank(release: Path, student: Path, exercise_id: str) -> None:
    """Put `exercise_id`'s region of the student's copy back to the release's stub (not written)."""
    name = exercise_file(exercise(exercise_id))
    write_regions(student, exercise_id, regions_of(source_texts(release / name), exercise_id, name))


if __name__ == "__main__":
    main()

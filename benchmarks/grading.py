"""Grading speed at class scale, in one process run: a plain `pytest --nbval` pass over the notebooks (the yardstick),
the Grader's start (the instructor's tree copied and every expected value computed), one full submission (every
exercise written and correct, in the student's own text: each region carries the student's own comment, so nothing
is byte-identical to the reference or to a classmate), and a class of such submissions with --jobs 1 and 2.

    PYTHONPATH=. python benchmarks/grading.py [--students 4] [--exercises id ...]
"""

from __future__ import annotations

import argparse
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from armlab.exercises import make_student_release
from armlab.exercises.registry import EXERCISES, exercise
from armlab.grading.grade import Grader, grade_class
from armlab.grading.splice import write_regions
from armlab.grading.submission import exercise_file, read_submission, regions_of, source_texts

ROOT = Path(__file__).resolve().parents[1]


def _own_words(body: str, student: int) -> str:
    """The reference body with the student's own comment on top: correct, and a text of its own."""
    indent = body[:len(body) - len(body.lstrip())]
    return f"{indent}# worked out by student {student} for the lab\n{body}"


def make_class(folder: Path, students: int, exercises: list[str]) -> list[Path]:
    release = folder / "release"
    make_student_release(ROOT, release)
    out = []
    for i in range(students):
        student = folder / "subs" / f"s{i:02d}"
        shutil.copytree(release, student)
        for exercise_id in exercises:
            name = exercise_file(exercise(exercise_id))
            bodies = regions_of(source_texts(ROOT / name), exercise_id, name)
            write_regions(student, exercise_id, [_own_words(b, i) for b in bodies])
        out.append(student)
    return out


def plain_nbval_pass() -> float:
    """Seconds of one plain `pytest --nbval` pass over every notebook, in one process (no xdist)."""
    t = time.perf_counter()
    subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", "-p", "no:xdist", "--nbval",
                    "--nbval-sanitize-with", "tests/nbval_sanitize.cfg", "notebooks"], cwd=ROOT, check=False,
                   stdout=subprocess.DEVNULL)
    return time.perf_counter() - t


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--students", type=int, default=4)
    parser.add_argument("--exercises", nargs="+", default=[e.id for e in EXERCISES])
    args = parser.parse_args()
    plain = plain_nbval_pass()
    with tempfile.TemporaryDirectory() as tmp:
        subs = make_class(Path(tmp), args.students, args.exercises)
        t = time.perf_counter()
        grader = Grader(ROOT, exercises=args.exercises)
        start = time.perf_counter() - t
        t = time.perf_counter()
        results = grader.grade(read_submission(subs[0], ROOT))
        one = time.perf_counter() - t
        runs = grader.runs
        grader.close()
        auto = [r for r in results.values() if not r.by_hand]         # written answers are graded by hand
        full = sum(r.score for r in auto) == sum(r.max_score for r in auto)
        print(f"sandbox: {grader.sandbox.kind}; {len(args.exercises)} exercises; the full submission scored "
              f"{'full marks' if full else 'BELOW full marks'} with {runs} notebook runs")
        print("| what | seconds | / plain nbval pass |")
        print("|---|---:|---:|")
        print(f"| plain `pytest --nbval notebooks` (one process) | {plain:.1f} | 1.00 |")
        print(f"| Grader start (expected values, once per class) | {start:.1f} | {start / plain:.2f} |")
        print(f"| one full submission | {one:.1f} | {one / plain:.2f} |")
        print()
        print("| jobs | class seconds | s / submission | submissions / hour |")
        print("|---:|---:|---:|---:|")
        for jobs in (1, 2):
            t = time.perf_counter()
            grade_class(Path(tmp) / "subs", Path(tmp) / f"out{jobs}", ROOT, jobs=jobs, exercises=args.exercises)
            dt = time.perf_counter() - t
            print(f"| {jobs} | {dt:.1f} | {dt / args.students:.1f} | {3600 * args.students / dt:.0f} |", flush=True)


if __name__ == "__main__":
    main()

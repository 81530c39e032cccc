"""Grading speed at class scale, in one process run: a plain `pytest --nbval` pass over the notebooks (the yardstick),
the Grader's start (the instructor's tree copied and the expected values of the written exercises computed), one
full submission (every exercise written and correct, in the student's own text: each region carries the student's
own comment, so nothing is byte-identical to the reference or to a classmate) with its runs one at a time and two
side by side (parallel=2: what the Gradescope autograder does on a 2-core container), and a class of such
submissions with --jobs 2 (its throughput against --jobs 1, which is the one-at-a-time submission).

Each row gives wall-clock seconds and the CPU seconds of this process and everything it started (a cpuacct cgroup
of its own where the machine has cgroup v1 and this runs as root: a sandbox's processes stay in it, whereas
bubblewrap hides theirs from getrusage; else getrusage of this process and the children waited for). On a shared
machine the wall clock depends on who else runs, the CPU seconds much less, so the ratios are given for both.
"""

from __future__ import annotations

import argparse
import atexit
import os
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from armlab_course.exercises import make_student_release
from armlab_course.exercises.registry import EXERCISES, exercise
from armlab_course.grading.grade import Grader, grade_class
from armlab_course.grading.splice import write_regions
from armlab_course.grading.submission import exercise_file, read_submission, regions_of, source_texts

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


_CPUACCT = Path("/sys/fs/cgroup/cpuacct")


def _own_cpuacct_group() -> Path | None:
    """A cpuacct cgroup (v1) holding this process, hence everything it starts from now on; None where there is none
    to make (not root, no cgroup v1)."""
    group = _CPUACCT / f"armlab-bench-{os.getpid()}"
    try:
        group.mkdir(exist_ok=True)
        (group / "cgroup.procs").write_text(str(os.getpid()))
    except OSError:
        return None

    def leave() -> None:                        # back to the root group, and the (then empty) group removed
        try:
            (_CPUACCT / "cgroup.procs").write_text(str(os.getpid()))
            group.rmdir()
        except OSError:
            pass

    atexit.register(leave)
    return group


_GROUP = _own_cpuacct_group()


def cpu_seconds() -> float:
    """CPU seconds (user + system) used so far by this process and what it started (see the module's text)."""
    if _GROUP is not None:
        return int((_GROUP / "cpuacct.usage").read_text()) / 1e9
    own, children = (resource.getrusage(w) for w in (resource.RUSAGE_SELF, resource.RUSAGE_CHILDREN))
    return own.ru_utime + own.ru_stime + children.ru_utime + children.ru_stime


class Timed:
    """Wall-clock and CPU seconds (cpu_seconds) of a `with` block."""

    def __enter__(self) -> Timed:
        self.wall, self.cpu = time.perf_counter(), cpu_seconds()
        return self

    def __exit__(self, *exc) -> None:
        self.wall, self.cpu = time.perf_counter() - self.wall, cpu_seconds() - self.cpu


def plain_nbval_pass() -> Timed:
    """Wall and CPU seconds of one plain `pytest --nbval` pass over every notebook, in one process (no xdist)."""
    with Timed() as timed:
        subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", "-p", "no:xdist", "--nbval",
                        "--nbval-sanitize-with", "tests/nbval_sanitize.cfg", "notebooks"], cwd=ROOT, check=False,
                       stdout=subprocess.DEVNULL)
    return timed


def _row(what: str, timed: Timed, plain: Timed) -> str:
    return (f"| {what} | {timed.wall:.1f} | {timed.wall / plain.wall:.2f} | {timed.cpu:.1f} | "
            f"{timed.cpu / plain.cpu:.2f} |")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--students", type=int, default=2)
    parser.add_argument("--exercises", nargs="+", default=[e.id for e in EXERCISES])
    parser.add_argument("--one-at-a-time-only", action="store_true",
                        help="only the plain pass, the start and one submission with its runs one at a time")
    args = parser.parse_args()
    plain = plain_nbval_pass()
    print(f"plain pass: {plain.wall:.1f} s, {plain.cpu:.1f} CPU s", flush=True)
    with tempfile.TemporaryDirectory() as tmp:
        subs = make_class(Path(tmp), max(args.students, 2), args.exercises)
        with Timed() as start:
            grader = Grader(ROOT, exercises=args.exercises)
        one = {}
        ways = ((1, subs[0]),) if args.one_at_a_time_only else ((1, subs[0]), (2, subs[1]))
        for parallel, student in ways:                              # two students: nothing shared from a cache
            grader.parallel = parallel
            runs = grader.runs
            with Timed() as one[parallel]:
                results = grader.grade(read_submission(student, ROOT))
            auto = [r for r in results.values() if not r.by_hand]         # written answers are graded by hand
            full = sum(r.score for r in auto) == sum(r.max_score for r in auto)
            print(f"parallel {parallel}: the full submission scored {'full marks' if full else 'BELOW full marks'} "
                  f"with {grader.runs - runs} notebook runs in {one[parallel].wall:.1f} s", flush=True)
        grader.close()
        print(f"sandbox: {grader.sandbox.kind}; {len(args.exercises)} exercises; CPU seconds from "
              f"{'a cpuacct cgroup' if _GROUP is not None else 'getrusage (a sandbox run is not counted)'}")
        print("| what | seconds | / plain nbval pass | CPU seconds | / plain nbval pass |")
        print("|---|---:|---:|---:|---:|")
        print(_row("plain `pytest --nbval notebooks` (one process)", plain, plain))
        print(_row("Grader start (expected values, once per class)", start, plain))
        print(_row("one full submission, its runs one at a time", one[1], plain))
        if 2 in one:
            print(_row("one full submission, two runs side by side (parallel=2)", one[2], plain))
        if args.one_at_a_time_only:
            return
        print()
        print("| jobs | class seconds (start included) | s / submission | submissions / hour |")
        print("|---:|---:|---:|---:|")
        print(f"| 1 | (one at a time) | {one[1].wall:.1f} | {3600 / one[1].wall:.0f} |")
        with Timed() as both:
            grade_class(Path(tmp) / "subs", Path(tmp) / "out2", ROOT, jobs=2, exercises=args.exercises)
        n = len(subs)
        print(f"| 2 | {both.wall:.1f} | {both.wall / n:.1f} | {3600 * n / both.wall:.0f} |", flush=True)


if __name__ == "__main__":
    main()

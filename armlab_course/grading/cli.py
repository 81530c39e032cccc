"""`python -m armlab grade` (instructors) and `python -m armlab check [EXERCISE]` (students): their options
(add_parsers, called by armlab.__main__) and what they do (main). Every bad option or path is one line on stderr and
a non-zero exit; `check` prints a line per exercise as it is known (written / blank / failing / by hand, with
points), then the report, and exits 1 when anything is blank or failing."""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from armlab._command_line import int_at_least, positive_seconds

from .run import Limits

__all__ = ["add_parsers", "main"]


def _version() -> str:
    from importlib.metadata import PackageNotFoundError, version

    try:
        return f"armlab {version('armlab')}"
    except PackageNotFoundError:
        return "armlab (not installed)"


def add_parsers(sub) -> None:
    """The `grade` and `check` subcommands."""
    grade = sub.add_parser("grade", help="grade a folder of submissions (one folder per student) into OUT")
    grade.add_argument("submissions")
    grade.add_argument("--out", required=True,
                       help="folder for grades.csv, <student>/results.json, feedback.md and, for you only, "
                            "similarity.csv and similarity.md")
    grade.add_argument("--jobs", type=int_at_least(1, 512), default=1,
                       help="submissions graded in parallel (default: 1)")
    grade.add_argument("--timeout", type=positive_seconds, default=300.0,
                       help="wall-clock seconds per notebook run (default: 300)")
    grade.add_argument("--reference", default=".", help="the instructor's checkout (default: .)")
    grade.add_argument("--unsafe-no-sandbox", action="store_true",
                       help="grade without a sandbox where none can run (student code then sees all you see)")
    grade.add_argument("--allow-shared-network", action="store_true",
                       help="where only the uid fallback can sandbox (root without namespaces), grade although "
                            "student code then shares this machine's network")
    grade.add_argument("--version", action="version", version=_version())
    check = sub.add_parser("check", help="run the public checks of each exercise in this checkout (students)")
    check.add_argument("exercise", nargs="?", default=None,
                       help="one exercise id (e.g. fk.euler): only its public checks, in seconds for a code exercise")
    check.add_argument("--timeout", type=positive_seconds, default=300.0,
                       help="wall-clock seconds per notebook run (default: 300)")
    check.add_argument("--unsafe-no-sandbox", action="store_true",
                       help="run without a sandbox where none can run")


def _limits(timeout: float) -> Limits:
    return Limits(timeout_s=timeout, cpu_s=int(timeout) + 10)


def _check(args: argparse.Namespace) -> int:
    from .check import missing_tools, self_check
    from .report import self_check_report
    from .sandbox import SandboxUnavailable

    missing = missing_tools()
    if missing:
        print(f"armlab check: cannot run: {', '.join(missing)} not installed in this Python "
              f"({sys.executable}); run `make lab` or `pip install {' '.join(missing)}`", file=sys.stderr)
        return 2
    if args.exercise is not None:
        from armlab_course.exercises.registry import EXERCISES

        if args.exercise not in {e.id for e in EXERCISES}:
            print(f"armlab check: no exercise {args.exercise!r}; the exercises: "
                  f"{', '.join(e.id for e in EXERCISES)}", file=sys.stderr)
            return 2
    started, seen = time.monotonic(), [0]

    def progress(exercise_id: str, result, status: str) -> None:
        seen[0] += 1
        points = f"{result.max_score} points" if result.by_hand else f"{result.score:g} / {result.max_score}"
        print(f"[{seen[0]}] {exercise_id}: {status}, {points} ({time.monotonic() - started:.0f} s)", flush=True)

    try:
        checked = self_check(Path.cwd(), _limits(args.timeout), unsafe=args.unsafe_no_sandbox, only=args.exercise,
                             progress=progress)
    except (SandboxUnavailable, OSError, ValueError) as e:
        print(f"armlab check: cannot run: {e}", file=sys.stderr)
        return 2
    print()
    print(self_check_report(checked.results, checked.blocked))
    return 0 if checked.ok else 1


def main(args: argparse.Namespace) -> int:
    if args.command == "check":
        return _check(args)
    try:
        from .grade import GraderChanged, grade_class
        from .results import total
    except ImportError:                  # a student release: it ships the self-check, not the grader
        print("armlab grade: grading is the instructor's: this student release holds no grader (check your work "
              "with `python -m armlab check`)", file=sys.stderr)
        return 2
    from .sandbox import SandboxUnavailable

    started = time.monotonic()
    done = [0]

    def progress(student: str, results: dict) -> None:
        done[0] += 1
        print(f"[{done[0]}] {student}: {total(results)} ({time.monotonic() - started:.0f} s)",
              file=sys.stderr, flush=True)

    try:
        graded = grade_class(args.submissions, args.out, args.reference, jobs=args.jobs, limits=_limits(args.timeout),
                             unsafe=args.unsafe_no_sandbox, progress=progress,
                             shared_network=args.allow_shared_network)
    except (NotADirectoryError, ValueError, SandboxUnavailable, GraderChanged, RuntimeError) as e:
        print(f"armlab grade: {e}", file=sys.stderr)
        return 2
    for student, results in graded.items():
        print(f"{student}: {total(results)}")
    print(f"wrote {Path(args.out) / 'grades.csv'}; similar regions, for your eyes only: "
          f"{Path(args.out) / 'similarity.md'}")
    return 0

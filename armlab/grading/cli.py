"""`python -m armlab grade` and `python -m armlab check`, called from armlab.__main__ with the parsed arguments."""

from __future__ import annotations

import argparse
from pathlib import Path

from .run import Limits

__all__ = ["main"]


def main(args: argparse.Namespace) -> int:
    from .report import table

    if args.command == "check":
        from .check import self_check

        print(table(self_check(Path.cwd())))
        return 0
    from .grade import grade_class

    if args.timeout <= 0:
        raise SystemExit(f"armlab grade: --timeout must be positive, got {args.timeout:g}")
    limits = Limits(timeout_s=args.timeout, cpu_s=int(args.timeout) + 10)
    try:
        graded = grade_class(args.submissions, args.out, args.reference, jobs=args.jobs, limits=limits)
    except (NotADirectoryError, ValueError) as e:
        raise SystemExit(f"armlab grade: {e}") from None
    for student, results in graded.items():
        print(f"{student}: {sum(r.score for r in results.values()):g} / {sum(r.max_score for r in results.values())}")
    print(f"wrote {Path(args.out) / 'grades.csv'}")
    return 0

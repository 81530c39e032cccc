"""Grading speed: seconds per submission and class throughput with 1 and 2 jobs, for N generated submissions (a
third correct, a third blank, a third wrong: the reference regions with one sign flipped in each exercise).

    PYTHONPATH=. python benchmarks/grading.py [--students 20] [--exercises fk.dh_transform ik.planar_ik]
"""

from __future__ import annotations

import argparse
import shutil
import tempfile
import time
from pathlib import Path

from armlab.exercises import make_student_release
from armlab.exercises.registry import exercise
from armlab.grading import grade_class
from armlab.grading.splice import write_regions
from armlab.grading.submission import exercise_file, regions_of, source_texts

ROOT = Path(__file__).resolve().parents[1]


def _wrong(body: str, student: int) -> str:
    """The reference body with one mistake (a cosine for a sine, or a minus for a plus) and the student's comment."""
    wrong = body.replace("np.sin", "np.cos", 1) if "np.sin" in body else body.replace(" - ", " + ", 1)
    indent = body[:len(body) - len(body.lstrip())]
    return f"{indent}# student {student}\n{wrong}"


def make_class(folder: Path, students: int, exercises: list[str]) -> None:
    release = folder / "release"
    make_student_release(ROOT, release)
    for i in range(students):
        student = folder / "subs" / f"s{i:02d}"
        shutil.copytree(release, student)
        kind = i % 3
        for exercise_id in exercises:
            name = exercise_file(exercise(exercise_id))
            bodies = regions_of(source_texts(ROOT / name), exercise_id, name)
            if kind == 1:
                continue                                  # blank
            if kind == 2:                                 # wrong, and different text per student (no shared result)
                bodies = [_wrong(b, i) for b in bodies]
            write_regions(student, exercise_id, bodies)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--students", type=int, default=20)
    parser.add_argument("--exercises", nargs="+", default=["fk.dh_transform", "ik.planar_ik"])
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        make_class(Path(tmp), args.students, args.exercises)
        print(f"{args.students} submissions (correct / blank / wrong in turn), exercises {', '.join(args.exercises)}")
        print("jobs  seconds  s/submission  submissions/min")
        for jobs in (1, 2):
            t = time.perf_counter()
            grade_class(Path(tmp) / "subs", Path(tmp) / f"out{jobs}", ROOT, jobs=jobs, exercises=args.exercises)
            dt = time.perf_counter() - t
            print(f"{jobs:>4}  {dt:7.1f}  {dt / args.students:12.2f}  {60 * args.students / dt:15.1f}")


if __name__ == "__main__":
    main()

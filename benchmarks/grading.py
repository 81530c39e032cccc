"""Grading speed: seconds per submission and class throughput with 1 and 2 jobs, in one process run, for N generated
submissions over several exercises: in turn correct (the reference regions), blank (the release as it is) and wrong
(the reference with one slip, a different text per student so that no result is shared). Each jobs setting grades
the class with a fresh Grader (nothing cached from the other).

    PYTHONPATH=. python benchmarks/grading.py [--students 20] [--exercises fk.dh_table ik.candidates ...]
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
EXERCISES = ["fk.dh_table", "ik.candidates", "calib.tag_homography"]
SLIPS = (("np.sin", "np.cos"), (" - ", " + "), (" + ", " - "), ("-x", "x"))   # the first that applies


def _wrong(body: str, student: int) -> str:
    """The reference body with one slip and the student's comment (so that each wrong text is new)."""
    old, new = next((o, n) for o, n in SLIPS if o in body)
    indent = body[:len(body) - len(body.lstrip())]
    return f"{indent}# student {student}\n{body.replace(old, new, 1)}"


def make_class(folder: Path, students: int, exercises: list[str]) -> dict[str, int]:
    """Write `students` submissions into folder/subs; returns how many of each kind."""
    release = folder / "release"
    make_student_release(ROOT, release)
    kinds = {"correct": 0, "blank": 0, "wrong": 0}
    for i in range(students):
        student = folder / "subs" / f"s{i:02d}"
        shutil.copytree(release, student)
        kind = ("correct", "blank", "wrong")[i % 3]
        kinds[kind] += 1
        for exercise_id in exercises:
            name = exercise_file(exercise(exercise_id))
            bodies = regions_of(source_texts(ROOT / name), exercise_id, name)
            if kind == "blank":
                continue
            if kind == "wrong":
                bodies = [_wrong(b, i) for b in bodies]
            write_regions(student, exercise_id, bodies)
    return kinds


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--students", type=int, default=20)
    parser.add_argument("--exercises", nargs="+", default=EXERCISES)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        kinds = make_class(Path(tmp), args.students, args.exercises)
        print(f"{args.students} submissions ({', '.join(f'{n} {k}' for k, n in kinds.items())}), "
              f"exercises {', '.join(args.exercises)}")
        print("| jobs | seconds | s / submission | submissions / min |")
        print("|---:|---:|---:|---:|")
        for jobs in (1, 2):
            t = time.perf_counter()
            grade_class(Path(tmp) / "subs", Path(tmp) / f"out{jobs}", ROOT, jobs=jobs, exercises=args.exercises)
            dt = time.perf_counter() - t
            print(f"| {jobs} | {dt:.1f} | {dt / args.students:.2f} | {60 * args.students / dt:.1f} |", flush=True)


if __name__ == "__main__":
    main()

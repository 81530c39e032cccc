"""The Gradescope autograder: the same grader as `python -m armlab grade`, on one submission.

    python -m armlab_course.grading.autograder build OUT     # make autograder: OUT/ and OUT.zip, the bundle to upload
    python -m armlab_course.grading.autograder run ROOT      # what run_autograder calls (ROOT: /autograder)

The bundle holds the instructor's tracked files (hidden checks included) with setup.sh and run_autograder
(tools/autograder/) at its top; Gradescope unpacks it into ROOT/source, puts the student's upload in
ROOT/submission and reads ROOT/results/results.json. Environment: ARMLAB_GRADE_EXERCISES (comma-separated exercise
ids; default every exercise), ARMLAB_GRADE_TIMEOUT (wall-clock seconds per notebook run; default 300) and
ARMLAB_ALLOW_SHARED_NETWORK=1 (grade in the uid fallback, where student code shares the container's network).
"""

from __future__ import annotations

import json
import os
import shutil
import sys
import tempfile
from pathlib import Path

from .run import Limits
from .splice import tracked_files

__all__ = ["SCRIPTS", "build_bundle", "limits_from_env", "exercises_from_env", "run"]

SCRIPTS = ("tools/autograder/setup.sh", "tools/autograder/run_autograder", "tools/autograder/pick-python")


def build_bundle(reference: Path | str, out: Path | str) -> Path:
    """Copy the reference checkout's tracked files into `out` (which must not exist), put the Gradescope scripts at
    its top and zip it to `out`.zip; returns the zip's path."""
    reference, out = Path(reference).resolve(), Path(out)
    if out.exists():
        raise FileExistsError(f"{out} exists: the bundle goes into a new folder")
    missing = [s for s in SCRIPTS if not (reference / s).is_file()]
    if missing:
        raise FileNotFoundError(f"{reference} lacks {', '.join(missing)}")
    for name in tracked_files(reference):
        if (reference / name).is_file():
            (out / name).parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(reference / name, out / name)
    for script in SCRIPTS:
        shutil.copy2(reference / script, out / Path(script).name)
    zip_path = out.with_suffix(".zip")
    zip_path.unlink(missing_ok=True)
    return Path(shutil.make_archive(str(out), "zip", root_dir=out))


def exercises_from_env() -> list[str] | None:
    """ARMLAB_GRADE_EXERCISES as a list of exercise ids (None: every exercise); unknown ids are refused later by
    the Grader, naming them."""
    text = os.environ.get("ARMLAB_GRADE_EXERCISES", "").strip()
    return [e.strip() for e in text.split(",") if e.strip()] or None


def limits_from_env() -> Limits:
    """The notebook run's limits from ARMLAB_GRADE_TIMEOUT (seconds, positive)."""
    text = os.environ.get("ARMLAB_GRADE_TIMEOUT", "300")
    try:
        timeout = float(text)
    except ValueError:
        raise ValueError(f"ARMLAB_GRADE_TIMEOUT must be a number of seconds, got {text!r}") from None
    if not timeout > 0:
        raise ValueError(f"ARMLAB_GRADE_TIMEOUT must be positive, got {text!r}")
    return Limits(timeout_s=timeout, cpu_s=int(timeout) + 10)


def run(root: Path | str) -> Path:
    """Grade ROOT/submission against ROOT/source and write ROOT/results/results.json; returns its path. The
    instructor's files and the results folder are made owner-only first, so that student code run as an
    unprivileged user (Gradescope's containers allow no namespaces: see armlab_course.grading.sandbox) reads neither."""
    from .grade import Grader, check_reference
    from .report import atomic_write, results_json
    from .sandbox import lock_down
    from .submission import read_submission

    root = Path(root)
    for part in ("source", "submission"):
        if not (root / part).is_dir():
            raise NotADirectoryError(f"{root / part}: no such folder (is {root} laid out as Gradescope's /autograder?)")
    (root / "results").mkdir(exist_ok=True)
    lock_down(root / "source", root / "results")
    with tempfile.TemporaryDirectory(dir=root, prefix="found-") as tmp:
        folder, refused = find_upload(root / "submission", Path(tmp) / "submission")
        if refused:
            return _write_refusal(root / "results" / "results.json", refused)
        submission = read_submission(folder, check_reference(root / "source"))    # read only: nothing runs
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count() or 1
    shared_network = os.environ.get("ARMLAB_ALLOW_SHARED_NETWORK", "") == "1"
    with Grader(root / "source", limits_from_env(), exercises_from_env(), written=submission.bodies,
                parallel=max(1, min(cores, 4)), shared_network=shared_network,
                private=[root / "submission"]) as grader:         # one submission: its runs side by side
        results = grader.grade(submission)
        grader.verify_sources()
    path = root / "results" / "results.json"
    atomic_write(path, results_json(results))
    return path


def find_upload(upload: Path, into: Path) -> tuple[Path, str | None]:
    """The submission's release files found wherever they are in the `upload` (flat, in a folder, in the release's
    layout: armlab_course.grading.upload), staged in the release's layout in the new folder `into`; said on stdout
    (Gradescope shows it). Returns (into, None), or (into, why the upload is refused)."""
    from .upload import find_release_files, refusal, stage

    found = find_release_files(upload)
    why = refusal(found)
    if why is None:
        stage(upload, found, into)
        print("release files found in the upload:")
        print("\n".join(f"  {name} <- {rel}" for name, rel in sorted(found.files.items())), flush=True)
    return into, why


def _write_refusal(path: Path, why: str) -> Path:
    """results.json for an upload that cannot be graded: score 0 and the reason, shown to the student."""
    from .report import atomic_write

    print(why, flush=True)
    atomic_write(path, json.dumps({"score": 0.0, "output": why, "tests": []}, indent=1) + "\n")
    return path


def main(argv: list[str]) -> int:
    usage = "usage: python -m armlab_course.grading.autograder build OUT | run ROOT"
    if len(argv) != 2 or argv[0] not in ("build", "run"):
        print(usage, file=sys.stderr)
        return 2
    try:
        if argv[0] == "build":
            print(f"wrote {build_bundle(Path.cwd(), argv[1])}")
        else:
            print(f"wrote {run(argv[1])}")
    except (OSError, ValueError, LookupError, RuntimeError) as e:
        print(f"armlab autograder: {e}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))

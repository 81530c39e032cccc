"""Run every benchmark in benchmarks/ in one process and print each one's table.

A benchmark is any benchmarks/*.py file (other than this one and files starting with "_") that prints its table when
run as a script (`if __name__ == "__main__": main()`). They run in name order; a benchmark that raises is reported
and the others still run; the exit code is 1 when any failed.

    .venv/bin/python benchmarks/run_all.py [name ...]     # e.g. run_all.py kinematics
"""

from __future__ import annotations

import runpy
import sys
import traceback
from pathlib import Path

HERE = Path(__file__).resolve().parent


def benchmark_files(names: list[str] | None = None) -> list[Path]:
    """The benchmark scripts to run, in name order (all of them, or those whose stem is in `names`)."""
    files = sorted(p for p in HERE.glob("*.py") if p.name != Path(__file__).name and not p.name.startswith("_"))
    if names:
        unknown = sorted(set(names) - {p.stem for p in files})
        if unknown:
            raise SystemExit(f"unknown benchmark(s) {unknown}; available: {[p.stem for p in files]}")
        files = [p for p in files if p.stem in names]
    return files


def main(argv: list[str]) -> int:
    failed = []
    if str(HERE) not in sys.path:
        sys.path.insert(0, str(HERE))
    saved_argv = sys.argv
    for path in benchmark_files(argv):
        print(f"=== {path.stem} ===", flush=True)
        sys.argv = [str(path)]           # each benchmark runs with its defaults, not with run_all's arguments
        try:
            runpy.run_path(str(path), run_name="__main__")
        except SystemExit as e:          # a script may end with sys.exit(...)
            if e.code not in (None, 0):
                failed.append(path.stem)
                print(f"{path.stem} exited with {e.code}")
        except Exception:
            failed.append(path.stem)
            traceback.print_exc()
        finally:
            sys.argv = saved_argv
        print(flush=True)
    if failed:
        print(f"failed: {', '.join(failed)}")
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))

"""Running the demo again in one process (a student re-running a cell) does not grow the memory: the detection's
per-camera ray maps (about 14 MB a camera) were cached by the camera object's identity, nine cameras deep, so every
run's new (but equal) calibration added another 14 MB; they are now cached by the camera's values, two deep, and
hold no camera. Measured as the process's resident memory after each run (the ray maps are large numpy arrays, so
they go back to the system when freed)."""

from __future__ import annotations

import contextlib
import gc
import io

from armlab.demo import run_demo

RUNS = 4                 # the first fills the caches; the growth is measured over the other three
MAX_GROWTH_MB = 25.0     # the old caches added about 14 MB a run (42 MB over three runs)


def _rss_mb() -> float:
    with open("/proc/self/status") as status:
        for line in status:
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) / 1024.0
    raise RuntimeError("no VmRSS in /proc/self/status")


def test_repeated_demo_runs_do_not_grow_the_memory(tmp_path):
    rss = []
    for k in range(RUNS):
        with contextlib.redirect_stdout(io.StringIO()):
            run_demo(str(tmp_path / f"run{k}"), seed=0, level=1, html=False)
        gc.collect()
        rss.append(_rss_mb())
    growth = rss[-1] - rss[0]
    assert growth < MAX_GROWTH_MB, f"resident memory after each run (MB): {[round(r) for r in rss]}"

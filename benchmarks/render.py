"""Speed of the simulated RGB-D camera: ms per 1280x720 frame, against the previous renderer, in one process.

    .venv/bin/python benchmarks/render.py [--before REV] [--repeats N]

Rows: board only, 10 blocks, 30 blocks + arm; columns: the "ideal" preset (exact pinhole, no noise) and the
"realistic" one (lens distortion, blur, pixel and depth noise, bias, dropouts), for this renderer ("now") and for the
renderer of git revision REV ("before"; default 321f6f7, the first renderer: its armlab/sim render, raster, faces,
sensor and camera modules are read with `git show` into a temporary package, everything else is shared), then the
speed-up before / now. Each figure is the minimum over `repeats` captures (the machines are shared: the minimum is
the least disturbed run), the two renderers alternating capture by capture. Two tables: OpenCV on one thread (the
station goal: <= 30 ms per realistic frame on one core) and on its default thread count.
"""

from __future__ import annotations

import argparse
import importlib
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from types import SimpleNamespace

os.environ.setdefault("OMP_NUM_THREADS", "1")

import cv2  # noqa: E402
import numpy as np  # noqa: E402

from armlab.blocks import COLORS, ObjectState  # noqa: E402
from armlab.gripper_geometry import GRIPPER  # noqa: E402
from armlab.sim.camera import CameraRealism, SimCamera  # noqa: E402

REPO = Path(__file__).resolve().parents[1]
BEFORE_REV = "321f6f7"
OWN_MODULES = ("render", "raster", "faces", "sensor", "camera")     # the renderer's modules that changed


def scene(n_blocks: int, seed: int = 0) -> list[ObjectState]:
    rng = np.random.default_rng(seed)
    objs = []
    for i in range(n_blocks):
        edge = 38.0 if i % 2 else 25.0
        objs.append(ObjectState(COLORS[i % 6], "large" if i % 2 else "small", edge,
                                [rng.uniform(-420, 420), rng.uniform(-120, 440), edge / 2], rng.uniform(0, 1.5), id=i))
    return objs


def load_before(rev: str):
    """The SimCamera class of git revision `rev` (its renderer modules in a temporary package), or None with the
    reason when git or the revision is not available."""
    name = f"_armlab_sim_{rev}"
    folder = Path(tempfile.mkdtemp(prefix="armlab_bench_")) / name
    folder.mkdir()
    try:
        for module in OWN_MODULES:
            src = subprocess.run(["git", "-C", str(REPO), "show", f"{rev}:armlab/sim/{module}.py"], check=True,
                                 capture_output=True, text=True).stdout
            for other in OWN_MODULES:
                src = src.replace(f"from armlab.sim.{other} import", f"from {name}.{other} import")
            (folder / f"{module}.py").write_text(src)
    except (OSError, subprocess.CalledProcessError) as e:
        return None, f"git show {rev} failed: {getattr(e, 'stderr', '') or e}".strip()
    (folder / "__init__.py").write_text("")
    sys.path.insert(0, str(folder.parent))
    return importlib.import_module(f"{name}.camera").SimCamera, None


def min_ms(cameras: list, repeats: int) -> list[float]:
    """Minimum ms per capture of each camera, capturing them in turn `repeats` times (after one warm-up each)."""
    best = [float("inf")] * len(cameras)
    for cam in cameras:
        cam.capture()                   # warm the per-camera caches (lens maps, board canvas, noise pools)
    for _ in range(repeats):
        for i, cam in enumerate(cameras):
            t = time.perf_counter()
            cam.capture()
            best[i] = min(best[i], time.perf_counter() - t)
    return [1000 * b for b in best]


def table(threads: int, before_cls, repeats: int) -> None:
    cv2.setNumThreads(threads)
    presets = {"ideal": CameraRealism.ideal(), "realistic": CameraRealism()}
    cases = {"board only": (0, False), "10 blocks": (10, False), "30 blocks + arm": (30, True)}
    print(f"OpenCV threads: {cv2.getNumThreads()}  (ms per 1280x720 frame, minimum of {repeats})")
    head = f"{'scene':<17}" + "".join(f"{'now ' + p:>15}" for p in presets)
    if before_cls is not None:
        head += "".join(f"{'before ' + p:>18}" for p in presets) + "".join(f"{'x ' + p:>13}" for p in presets)
    print(head)
    for label, (n, with_arm) in cases.items():
        world = SimpleNamespace(objects=scene(n), time_s=0.0)
        q = np.array([0.3, -0.2, 0.3, 0.9, 0.2]) if with_arm else None
        arm = SimpleNamespace(q_true=q, gripper_opening_mm=40.0, gripper_geometry=GRIPPER) if with_arm else None
        classes = [SimCamera] + ([before_cls] if before_cls is not None else [])
        ms = {}
        for name, realism in presets.items():
            ms[name] = min_ms([cls(world, arm, realism=realism, seed=0) for cls in classes], repeats)
        row = f"{label:<17}" + "".join(f"{ms[p][0]:>12.1f} ms" for p in presets)
        if before_cls is not None:
            row += "".join(f"{ms[p][1]:>15.1f} ms" for p in presets)
            row += "".join(f"{ms[p][1] / ms[p][0]:>12.2f}x" for p in presets)
        print(row)


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--before", default=BEFORE_REV, help="git revision of the renderer to compare with")
    parser.add_argument("--repeats", type=int, default=15)
    args, _ = parser.parse_known_args(argv)        # (run_all.py passes benchmark names)
    before_cls, why = load_before(args.before)
    print(f"before = renderer at git {args.before}" if before_cls is not None else f"(no comparison: {why})")
    default_threads = cv2.getNumThreads()
    table(1, before_cls, args.repeats)
    print()
    table(default_threads, before_cls, args.repeats)


if __name__ == "__main__":
    main()

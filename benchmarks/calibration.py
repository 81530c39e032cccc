"""Per-station intrinsics and depth refinement of the extrinsic, on simulated stations of several seeds.

    .venv/bin/python benchmarks/calibration.py [n_stations]

For each station (make_station("sim", seed=s, scene="empty"), s = 0 ... n_stations - 1; default 6) the AprilTag
extrinsic and the depth correction are computed from one frame with three intrinsics: the saved checkerboard set
data/checkerboard (another camera's: the realistic camera of seed 0, "before"), the station camera's own set
(tasks.perception.station_intrinsics, "after"), and the own set followed by calibration.refine_extrinsic_from_depth.
Prints one table from one run: focal and principal-point error of K, the camera-centre error of the extrinsic
(mm) and its angle (deg), and the 50 mm grid's world error after depth correction (mean / max mm, truth pixels,
points hidden by the arm left out); then ms for a station's own set (render 16 views + calibrate, first call) and
for a cached call.
"""

from __future__ import annotations

import os
import sys
import time

os.environ.setdefault("OMP_NUM_THREADS", "1")

import cv2  # noqa: E402
import numpy as np  # noqa: E402

from armlab import calibration as cal  # noqa: E402
from armlab import make_station  # noqa: E402
from armlab.camera import Camera  # noqa: E402
from armlab.lab import lab_config  # noqa: E402
from armlab.tasks.perception import checkerboard_intrinsics, station_intrinsics  # noqa: E402

cv2.setNumThreads(1)


def evaluate(station, frame, K, dist, refine: bool = False) -> dict[str, float]:
    """K's errors against the truth, the tag (optionally depth-refined) extrinsic's errors, the grid world error."""
    truth = station.camera.truth
    camera = Camera(K, dist, cal.calibrate_extrinsics(frame.rgb, K, dist).T_cam_world)
    if refine:
        camera = camera.with_pose(cal.refine_extrinsic_from_depth(frame.depth, camera).T_cam_world)
    grid = lab_config().grid_points()
    uv = truth.project(grid)
    visible = cal.visible_grid_points(truth, frame.depth, grid, uv)
    corrected = cal.fit_depth_correction(frame.depth, camera).apply(frame.depth)
    g = cal.grid_world_error(camera, corrected, grid[visible], uv[visible])
    k = cal.compare_intrinsics(K, truth.K)
    e = cal.compare_extrinsics(camera.T_cam_world, truth.T_cam_world)
    return {"focal_pct": abs(k["focal_rel_pct"]), "pp_px": float(np.hypot(k["dcx_px"], k["dcy_px"])),
            "pos_mm": e["position_mm"], "angle_deg": e["angle_deg"], "grid_mean": g.mean_mm, "grid_max": g.max_mm}


def main(n_stations: int = 6) -> None:
    saved = checkerboard_intrinsics()
    rows, first_ms, cached_ms = [], [], []
    for seed in range(n_stations):
        station = make_station("sim", seed=seed, scene="empty")
        frame = station.camera.capture()
        t = time.perf_counter()
        own = station_intrinsics(station)
        first_ms.append(1000 * (time.perf_counter() - t))
        t = time.perf_counter()
        station_intrinsics(station)
        cached_ms.append(1000 * (time.perf_counter() - t))
        for label, (K, dist), refine in (("saved set (seed-0 camera)", saved, False), ("own set", own, False),
                                         ("own set + depth refinement", own, True)):
            rows.append((seed, label, evaluate(station, frame, K, dist, refine)))
    print(f"Intrinsics per station: {n_stations} simulated stations (realistic, empty board), one frame each")
    print(f"{'station':>7}  {'intrinsics':<28}{'focal %':>8}{'pp px':>7}{'camera mm':>10}{'deg':>6}"
          f"{'grid mean / max mm':>20}")
    for seed, label, r in rows:
        print(f"{seed:>7}  {label:<28}{r['focal_pct']:>8.3f}{r['pp_px']:>7.2f}{r['pos_mm']:>10.2f}"
              f"{r['angle_deg']:>6.2f}{r['grid_mean']:>11.2f} / {r['grid_max']:5.2f}")
    for label in dict.fromkeys(lab for _, lab, _ in rows):
        sel = [r for _, lab, r in rows if lab == label]
        print(f"{'mean':>7}  {label:<28}{np.mean([r['focal_pct'] for r in sel]):>8.3f}"
              f"{np.mean([r['pp_px'] for r in sel]):>7.2f}{np.mean([r['pos_mm'] for r in sel]):>10.2f}"
              f"{np.mean([r['angle_deg'] for r in sel]):>6.2f}{np.mean([r['grid_mean'] for r in sel]):>11.2f} / "
              f"{np.mean([r['grid_max'] for r in sel]):5.2f}")
    print(f"station_intrinsics ms: first call (render 16 views + calibrate) median {np.median(first_ms):.0f}, "
          f"cached call median {np.median(cached_ms):.2f}")


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 6)

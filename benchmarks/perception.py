"""Block detection accuracy and speed on a seeded simulated set, with the true camera and with the camera a student
calibrates (checkerboard intrinsics from data/checkerboard + AprilTag extrinsics + depth-plane correction).

    .venv/bin/python benchmarks/perception.py [n_frames]

The set: n_frames (default 32) realistic frames cycling through singles, stacks 2-3 high, the events' levels 2-3
(stacks, distractors) and "to the sky", every other one with the arm posed over the board beside a block; seeds 100...
(the colour model in data/colour_model.json was fitted on seeds 1000-1023). Prints one table from one run:
recall, precision, colour / size / levels accuracy, position and yaw errors, the lab report's HSV table on the same
faces, the 50 mm grid world error before/after depth correction (scene "empty", truth pixels), and ms per frame for
detection and for tag calibration.
"""

from __future__ import annotations

import os
import sys
import time

os.environ.setdefault("OMP_NUM_THREADS", "1")

import cv2  # noqa: E402
import numpy as np  # noqa: E402

from armlab import calibration, make_station  # noqa: E402
from armlab.camera import Camera  # noqa: E402
from armlab.detection import detect_objects, hsv_table_classify  # noqa: E402
from armlab.lab import lab_config  # noqa: E402
from armlab.sim.checkerboard import load_dataset  # noqa: E402
from armlab.sim.scoring import Score, case_specs, corrected_depth, score_frame, sim_case  # noqa: E402

cv2.setNumThreads(1)


def checkerboard_intrinsics():
    images, meta = load_dataset()
    result = calibration.calibrate_intrinsics(images, tuple(meta["pattern_size"]), meta["square_mm"])
    return result.K, result.dist


def student_camera(rgb, K, dist) -> tuple[Camera, float]:
    """The calibrated camera of a frame (tag extrinsics with the checkerboard intrinsics) and the ms it took."""
    t = time.perf_counter()
    ext = calibration.calibrate_extrinsics(rgb, K, dist)
    ms = 1000 * (time.perf_counter() - t)
    w, h = lab_config().image_size
    return Camera(K, dist, ext.T_cam_world, w, h), ms


def grid_errors(K, dist) -> list[tuple[str, float, float]]:
    """Grid world error (mean, max mm) before and after depth correction, for the true and the calibrated camera."""
    station = make_station("sim", seed=7, scene="empty")
    frame = station.camera.capture()
    truth = station.camera.truth
    grid = lab_config().grid_points()
    grid = grid[~lab_config().on_robot_base(grid, margin_mm=40.0)]   # the arm's base stands there
    uv = truth.project(grid)
    calibrated, _ = student_camera(frame.rgb, K, dist)
    rows = []
    for name, cam in (("true camera", truth), ("calibrated", calibrated)):
        for label, depth in (("raw", frame.depth),
                             ("corrected", calibration.fit_depth_correction(frame.depth, cam).apply(frame.depth))):
            n = calibration.grid_world_error(cam, depth, grid, uv).norm
            rows.append((f"grid world error, {name}, {label} depth", float(np.nanmean(n)), float(np.nanmax(n))))
    return rows


def main(n_frames: int = 32) -> None:
    K, dist = checkerboard_intrinsics()
    cases = [sim_case(*spec) for spec in case_specs(n_frames, 100)]
    scores = {"true camera": Score(), "calibrated": Score()}
    det_ms, tag_ms, hsv_hits, hsv_none, n_hsv = [], [], 0, 0, 0
    for case in cases:
        cam, ms = student_camera(case.rgb, K, dist)
        tag_ms.append(ms)
        for name, camera in (("true camera", case.camera), ("calibrated", cam)):
            depth = corrected_depth(case, camera)
            detect_objects(case.rgb, depth, camera, case.arm_q)            # warm the per-camera cache
            t = time.perf_counter()
            found = detect_objects(case.rgb, depth, camera, case.arm_q)
            if name == "calibrated":
                det_ms.append(1000 * (time.perf_counter() - t))
            frame = score_frame(found, case.truth)
            scores[name].add(frame)
            if name == "true camera":
                pairs = [(d, t) for d, t in frame.pairs if d.shape == "cube" and t.is_block]
                labels = hsv_table_classify([d.mean_rgb for d, _ in pairs]) if pairs else []
                hsv_hits += sum(lab == t.obj.color for lab, (_, t) in zip(labels, pairs))
                hsv_none += labels.count("none")
                n_hsv += len(pairs)
    m = {k: s.metrics() for k, s in scores.items()}
    print(f"Block detection on {len(cases)} simulated frames ({m['true camera']['blocks']} visible blocks, "
          f"seeds 100-{100 + len(cases) - 1}, half with the arm over the board)")
    print(f"{'metric':<52}{'true camera':>14}{'calibrated':>14}{'goal':>10}")
    rows = [("recall", "recall", "{:.3f}", "1"), ("precision", "precision", "{:.3f}", "1"),
            ("distractors reported as distractors", "distractor_recall", "{:.3f}", "1"),
            ("colour accuracy", "color_acc", "{:.3f}", "1"), ("size accuracy", "size_acc", "{:.3f}", "1"),
            ("stack levels accuracy", "levels_acc", "{:.3f}", ""),
            ("position error mean (mm)", "pos_mean_mm", "{:.2f}", "< 2"),
            ("position error max (mm)", "pos_max_mm", "{:.2f}", "< 5"),
            ("yaw error mean (deg)", "yaw_mean_deg", "{:.2f}", "< 2"),
            ("yaw error max (deg)", "yaw_max_deg", "{:.2f}", "< 2")]
    for label, key, fmt, goal in rows:
        print(f"{label:<52}" + "".join(f"{fmt.format(m[k][key]):>14}" for k in scores) + f"{goal:>10}")
    print(f"{'colour accuracy, lab report HSV table (same faces)':<52}{hsv_hits / max(n_hsv, 1):>14.3f}{'':>14}"
          f"{'':>10}")
    print(f"{'  faces the HSV table leaves unlabelled':<52}{hsv_none:>14d}")
    for label, mean, mx in grid_errors(K, dist):
        print(f"{label + ' mean / max (mm)':<52}{f'{mean:.2f} / {mx:.2f}':>14}")
    print(f"{'detection ms per 1280x720 frame (median / max)':<52}"
          f"{f'{np.median(det_ms):.1f} / {np.max(det_ms):.1f}':>14}{'':>14}{'< 20':>10}")
    print(f"{'tag calibration ms per frame (median / max)':<52}{f'{np.median(tag_ms):.1f} / {np.max(tag_ms):.1f}':>14}")


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 32)

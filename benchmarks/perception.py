"""Block detection accuracy and speed on a seeded simulated set, with the true camera and with the camera a student
calibrates (checkerboard intrinsics from the frame's own camera, tasks.perception.station_intrinsics, + AprilTag
extrinsics + depth-plane correction).

    .venv/bin/python benchmarks/perception.py [n_frames]

The set: n_frames (default 32) realistic frames cycling through singles, stacks 2-3 high, the events' levels 2-3
(stacks, distractors) and "to the sky", every other one with the arm posed over the board beside a block; seeds 100...
(the colour model in data/colour_model.json was fitted on seeds 1000-1023). Prints one table from one run:
recall, precision, colour / size / levels accuracy, position and yaw errors, the lab report's HSV table on the same
faces, the 50 mm grid world error before and after calibration as notebook 01 measures it (visible grid points of
the empty board, truth pixels), and ms per frame for detection (each frame's best of 3 runs, one core) and for tag
calibration.
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
from armlab.sim.camera import CameraRealism  # noqa: E402
from armlab.sim.checkerboard import load_dataset  # noqa: E402
from armlab.sim.detection_eval import DetectionScore, case_specs, corrected_depth, score_frame, sim_case  # noqa: E402
from armlab.tasks.perception import station_intrinsics  # noqa: E402

cv2.setNumThreads(1)
W = 78          # the metric column's width
REPEATS = 3     # detection runs per frame (the table gives each frame's fastest)


def _timed_ms(fn, *args) -> float:
    t = time.perf_counter()
    fn(*args)
    return 1000 * (time.perf_counter() - t)


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
    """The 50 mm grid's world error (mean, max mm) as notebook 01 measures it: the station whose camera took the
    checkerboard set, empty board; before = factory K + tape-measured extrinsic + raw depth, after = checkerboard K +
    tag extrinsic + depth-plane correction; plus the true camera with raw and corrected depth. Only grid points the
    depth image really shows count (calibration.visible_grid_points): points under the sleeping arm read the arm's
    height, which is not a calibration error (counting them gave a "max" of about 180 mm)."""
    _, meta = load_dataset()
    station = make_station("sim", seed=0, scene="empty", camera_realism=CameraRealism.realistic(meta["seed"]))
    frame = station.camera.capture()
    truth = station.camera.truth
    cfg = lab_config()
    grid = cfg.grid_points()
    uv = truth.project(grid)
    visible = calibration.visible_grid_points(truth, frame.depth, grid, uv)
    grid, uv = grid[visible], uv[visible]
    calibrated, _ = student_camera(frame.rgb, K, dist)
    hand = Camera(cfg.factory_K, cfg.factory_dist, calibration.hand_measured_extrinsic(), *cfg.image_size)

    def corrected(cam):
        return calibration.fit_depth_correction(frame.depth, cam).apply(frame.depth)

    rows = []
    for label, cam, depth in (("before: factory K, tape extrinsic, raw depth", hand, frame.depth),
                              ("after: checkerboard K, tags, corrected depth", calibrated, corrected(calibrated)),
                              ("true camera, raw depth", truth, frame.depth),
                              ("true camera, corrected depth", truth, corrected(truth))):
        n = calibration.grid_world_error(cam, depth, grid, uv).norm
        rows.append((f"grid error mean / max (mm), {label}", float(np.nanmean(n)), float(np.nanmax(n))))
    return rows


def main(n_frames: int = 32) -> None:
    K, dist = checkerboard_intrinsics()
    cases = [sim_case(*spec) for spec in case_specs(n_frames, 100)]
    scores = {"true camera": DetectionScore(), "calibrated": DetectionScore()}
    det_ms, tag_ms, hsv_hits, hsv_none, n_hsv = [], [], 0, 0, 0
    for case in cases:   # each seed is another camera: calibrate its intrinsics from its own checkerboard set
        case_K, case_dist = station_intrinsics(make_station("sim", seed=case.seed, scene=case.scene))
        cam, ms = student_camera(case.rgb, case_K, case_dist)
        tag_ms.append(ms)
        for name, camera in (("true camera", case.camera), ("calibrated", cam)):
            depth = corrected_depth(case, camera)
            found = detect_objects(case.rgb, depth, camera, case.arm_q)    # also warms the per-camera ray cache
            if name == "calibrated":   # best of REPEATS runs: the machine is shared, the slowest run measures others
                det_ms.append(min(_timed_ms(detect_objects, case.rgb, depth, camera, case.arm_q)
                                  for _ in range(REPEATS)))
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
    print(f"{'metric':<{W}}{'true camera':>14}{'calibrated':>14}{'goal':>10}")
    rows = [("recall", "recall", "{:.3f}", "1"), ("precision", "precision", "{:.3f}", "1"),
            ("distractors reported as distractors", "distractor_recall", "{:.3f}", "1"),
            ("colour accuracy", "color_acc", "{:.3f}", "1"), ("size accuracy", "size_acc", "{:.3f}", "1"),
            ("stack levels accuracy", "levels_acc", "{:.3f}", ""),
            ("position error mean (mm)", "pos_mean_mm", "{:.2f}", "< 2"),
            ("position error max (mm)", "pos_max_mm", "{:.2f}", "< 5"),
            ("yaw error mean (deg)", "yaw_mean_deg", "{:.2f}", "< 2"),
            ("yaw error max (deg)", "yaw_max_deg", "{:.2f}", "< 2")]
    for label, key, fmt, goal in rows:
        print(f"{label:<{W}}" + "".join(f"{fmt.format(m[k][key]):>14}" for k in scores) + f"{goal:>10}")
    print(f"{'colour accuracy, lab report HSV table (same faces)':<{W}}{hsv_hits / max(n_hsv, 1):>14.3f}{'':>14}"
          f"{'':>10}")
    print(f"{'  faces the HSV table leaves unlabelled':<{W}}{hsv_none:>14d}")
    for label, mean, mx in grid_errors(K, dist):
        print(f"{label:<{W}}{f'{mean:.2f} / {mx:.2f}':>14}{'':>14}{'< 2 / < 5' if 'after' in label else '':>10}")
    print(f"{f'detection ms per 1280x720 frame, best of {REPEATS} (median / max)':<{W}}"
          f"{f'{np.median(det_ms):.1f} / {np.max(det_ms):.1f}':>14}{'':>14}{'< 20':>10}")
    print(f"{'tag calibration ms per frame (median / max)':<{W}}"
          f"{f'{np.median(tag_ms):.1f} / {np.max(tag_ms):.1f}':>14}")


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 32)

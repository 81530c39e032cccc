"""The headless demo behind `make demo` / `python -m armlab demo`: the whole pipeline on the simulator.

Steps: a simulated station with the sort 'n stack level-3 board (stacks two high, distractors); calibrate (camera
intrinsics from the saved checkerboard views, AprilTag extrinsics, depth correction; sag fit) through the task layer;
look and detect (accuracy against the simulator's truth); run the event autonomously (armlab.tasks.events); print
the score table (from the world's truth), a detection accuracy table and the placement errors; write into out/:
detections.png (annotated camera image), replay.html (meshcat snapshot that plays the run), replay.npz (the
recorded joint trajectory and world snapshots). Units: mm, rad, s.
"""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np

from armlab.files import atomic_path
from armlab.tasks.events import columns, event_station, run_event
from armlab.tasks.events.runner import see
from armlab.transforms import wrap_quarter

__all__ = ["run_demo", "detection_accuracy"]


def detection_accuracy(detected, objects, max_mm: float = 20.0) -> dict:
    """Match detected cubes to the true visible top faces (cubes only: the top of every column, and a block under a
    smaller one, whose face shows around it) by nearest top-face centre within max_mm. Returns counts and the errors
    (mm, deg) of the matched pairs."""
    tops = [o for c in columns(objects) for k, o in enumerate(c)
            if o.is_block and (k == len(c) - 1 or c[k + 1].edge < o.edge - 1.0)]
    cubes = [b for b in detected if b.is_block]
    pairs, used = [], set()
    for b in cubes:
        d = [np.linalg.norm(np.asarray(b.position) - [*t.position[:2], t.top_z]) if i not in used else np.inf
             for i, t in enumerate(tops)]
        if d and min(d) <= max_mm:
            i = int(np.argmin(d))
            used.add(i)
            pairs.append((b, tops[i]))
    xy = np.array([np.linalg.norm(np.asarray(b.position[:2]) - t.position[:2]) for b, t in pairs])
    dz = np.array([b.position[2] - t.top_z for b, t in pairs])
    yaw = np.abs(wrap_quarter([b.yaw - t.yaw for b, t in pairs]))
    return {"true_tops": len(tops), "detected": len(cubes), "matched": len(pairs),
            "distractors_flagged": sum(not b.is_block for b in detected),
            "colour_ok": sum(b.color == t.color for b, t in pairs), "size_ok": sum(b.size == t.size for b, t in pairs),
            "xy_mm": xy, "z_mm": dz, "yaw_deg": np.degrees(yaw)}


def _write_png(path: Path, rgb: np.ndarray) -> None:
    with atomic_path(path) as tmp:
        if not cv2.imwrite(str(tmp), cv2.cvtColor(rgb, cv2.COLOR_RGB2BGR)):
            raise OSError(f"could not write {path}")


def _write_html(path: Path, replay) -> None:
    from armlab.viz import Viewer

    with Viewer(frames=False) as viewer:
        replay.to_viewer(viewer, fps=4)
        viewer.save_html(path)


def _stats(name: str, v: np.ndarray, unit: str) -> str:
    if len(v) == 0:
        return f"{name:<26} {'-':>8} {'-':>8}"
    return f"{name:<26} {np.mean(np.abs(v)):8.2f} {np.max(np.abs(v)):8.2f}  {unit}"


def run_demo(out_dir: str = "out", seed: int = 0, event: str = "sort_stack", level: int = 3,
             html: bool = True) -> int:
    """Run the demo (module notes); returns a process exit code (0 when the event got full marks)."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    from armlab.tasks import start_session

    print(f"armlab demo: {event} level {level} on the simulator (seed {seed})")
    station = event_station(event, level, seed=seed)
    session = start_session(station)           # calibrates the camera, fits the sag model
    print(f"calibration: {session.calibration.notes}")
    look = see(session)
    acc = detection_accuracy(look.objects, station.world.objects)
    from armlab.detection import draw_detections

    _write_png(out / "detections.png", draw_detections(look.frame.rgb, look.objects, session.calibration.camera))

    result = run_event(session, event, level, seed=seed)
    print()
    print("SCORE (from the simulator's ground truth)")
    print(result.score.table())
    print(result.summary())
    print()
    print("ACCURACY")
    print(f"{'quantity':<26} {'mean':>8} {'max':>8}")
    print(f"detection: {acc['matched']} of {acc['true_tops']} visible block tops found "
          f"({acc['detected']} cubes reported, {acc['distractors_flagged']} objects flagged as distractors), "
          f"colour right {acc['colour_ok']}/{acc['matched']}, size right {acc['size_ok']}/{acc['matched']}")
    print(_stats("detection x-y error", acc["xy_mm"], "mm"))
    print(_stats("detection z error", acc["z_mm"], "mm"))
    print(_stats("detection yaw error", acc["yaw_deg"], "deg"))
    err = result.placement_errors
    print(_stats("placement x-y error", np.linalg.norm(err[:, :2], axis=1), "mm"))
    print(_stats("placement z error", err[:, 2], "mm"))
    if result.replay is not None:
        result.replay.save(out / "replay.npz")
        if html:
            _write_html(out / "replay.html", result.replay)
    print()
    print(f"wrote {out / 'detections.png'}" + (f", {out / 'replay.html'}" if html else "") +
          f", {out / 'replay.npz'}")
    return 0 if result.score.full_marks else 1

"""Labelled frames for the colour model's fit: a folder of RGB-D frames (real or simulated) and a labels file.

`python -m armlab colors fit --frames FOLDER` refits data/color_model.json from them (without --frames: from the
kit's simulated training frames). FOLDER holds `labels.json`:

    {"format": "armlab-color-labels/1",
     "calibration": "calibration.json",          # armlab.calibration.save_calibration's file, relative to FOLDER
     "frames": [{"rgb": "frame_000.png",          # 8-bit colour image (PNG or JPEG), read as RGB
                 "depth": "frame_000.npy",        # (H, W) depth in mm aligned to rgb, NaN = no return (numpy .npy)
                 "arm_q": [0, 0, 0, 0, 0],        # optional: the arm's joints (rad), to mask it out
                 "blocks": [{"pixel": [612, 344], "color": "red"}, ...]}]}   # a pixel on a block's top face

Each labelled pixel picks the detected block face (armlab.detection.detect_objects with the calibration's camera
and depth correction) whose outline holds it; the face's white-balanced mean colour is the sample, exactly what
the detector classifies. A label no face holds, a colour outside armlab.blocks.COLORS or a missing file is an
error naming the frame and the label. Units: pixels (u right, v down), mm.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from armlab.blocks import COLORS
from armlab.files import read_json
from armlab.schemas import file_name, number, strict_object, vector

__all__ = ["LABELS_FILE", "LABELS_FORMAT", "LabelledFrame", "load_labelled_frames", "labelled_colours"]

LABELS_FILE = "labels.json"
LABELS_FORMAT = "armlab-color-labels/1"
OUTLINE_SLACK_PX = 2.0     # a labelled pixel this close outside a face's outline still picks it


@dataclass(frozen=True)
class LabelledFrame:
    """One frame: rgb (H, W, 3) uint8, depth (H, W) float32 mm, arm_q (5,) rad or None, labels [((u, v), colour)],
    and its name (the rgb file) for messages."""

    name: str
    rgb: np.ndarray
    depth: np.ndarray
    arm_q: np.ndarray | None
    labels: tuple[tuple[tuple[float, float], str], ...]


SCHEMA = strict_object({
    "format": {"const": LABELS_FORMAT}, "calibration": file_name(),
    "frames": vector(strict_object({
        "rgb": file_name(), "depth": file_name(), "arm_q": {"anyOf": [{"type": "null"}, vector(number(-100, 100), 5)]},
        "blocks": vector(strict_object({"pixel": vector(number(-1e5, 1e5), 2), "color": {"enum": list(COLORS)}},
                                       required=("pixel", "color")), max_items=1000)},
        required=("rgb", "depth", "blocks")), min_items=1, max_items=100_000)},
    required=("format", "calibration", "frames"))
"""The declared schema of labels.json (armlab.schemas): file names inside the folder, pixels, colours."""


def _field(raw: dict, key: str, where: str):
    if not isinstance(raw, dict) or key not in raw:
        raise ValueError(f"{where}: missing field {key!r}")
    return raw[key]


def _read_rgb(path: Path) -> np.ndarray:
    bgr = cv2.imread(str(path), cv2.IMREAD_COLOR) if path.is_file() else None
    if bgr is None:
        raise ValueError(f"{path}: colour image not found or not readable")
    return cv2.cvtColor(bgr, cv2.COLOR_BGR2RGB)


def _read_depth(path: Path, shape: tuple[int, int]) -> np.ndarray:
    if not path.is_file():
        raise ValueError(f"{path}: depth file not found")
    try:
        depth = np.load(path, allow_pickle=False)
    except ValueError as e:
        raise ValueError(f"{path}: not a numpy depth array ({e})") from None
    if depth.shape != shape or depth.dtype.kind != "f":
        raise ValueError(f"{path}: depth must be a float (H, W) = {shape} array in mm, got {depth.dtype} "
                         f"{depth.shape}")
    return depth.astype(np.float32)


def load_labelled_frames(folder) -> tuple[list[LabelledFrame], object]:
    """The frames and the Calibration of a labelled folder (module notes); ValueError naming the problem."""
    from armlab.calibration import load_calibration

    folder = Path(folder)
    raw = read_json(folder / LABELS_FILE, "colour labels", schema=SCHEMA)
    where = str(folder / LABELS_FILE)
    if not isinstance(raw, dict) or raw.get("format") != LABELS_FORMAT:
        raise ValueError(f"{where}: not armlab colour labels (format must be {LABELS_FORMAT!r})")
    calibration = load_calibration(folder / str(_field(raw, "calibration", where)))
    frames_raw = _field(raw, "frames", where)
    if not isinstance(frames_raw, list) or not frames_raw:
        raise ValueError(f"{where}: 'frames' must be a non-empty list")
    frames = []
    for i, fr in enumerate(frames_raw):
        at = f"{where}, frame {i}"
        rgb = _read_rgb(folder / str(_field(fr, "rgb", at)))
        depth = _read_depth(folder / str(_field(fr, "depth", at)), rgb.shape[:2])
        arm_q = fr.get("arm_q")
        if arm_q is not None:
            arm_q = np.asarray(arm_q, float)
            if arm_q.shape != (5,) or not np.isfinite(arm_q).all():
                raise ValueError(f"{at}: arm_q must be 5 finite joint angles (rad), got {fr['arm_q']!r}")
        labels = []
        for k, b in enumerate(_field(fr, "blocks", at)):
            pixel, colour = _field(b, "pixel", f"{at}, block {k}"), _field(b, "color", f"{at}, block {k}")
            if colour not in COLORS:
                raise ValueError(f"{at}, block {k}: colour {colour!r} is not one of {COLORS}")
            uv = np.asarray(pixel, float)
            if uv.shape != (2,) or not np.isfinite(uv).all():
                raise ValueError(f"{at}, block {k}: pixel must be [u, v], got {pixel!r}")
            labels.append(((float(uv[0]), float(uv[1])), colour))
        frames.append(LabelledFrame(str(fr["rgb"]), rgb, depth, arm_q, tuple(labels)))
    return frames, calibration


def labelled_colours(frames: list[LabelledFrame], calibration) -> tuple[np.ndarray, list[str]]:
    """White-balanced mean colours (N, 3) of the labelled faces and their colours: ColorModel.fit's samples."""
    from armlab.detection.detect import detect_objects

    colours, names = [], []
    for frame in frames:
        found = [b for b in detect_objects(frame.rgb, calibration.depth_correction.apply(frame.depth),
                                           calibration.camera, frame.arm_q) if b.contour is not None]
        for (u, v), colour in frame.labels:
            inside = [(cv2.pointPolygonTest(b.contour.reshape(-1, 1, 2).astype(np.float32), (u, v), True), b)
                      for b in found]
            best = max(inside, key=lambda item: item[0], default=None)
            if best is None or best[0] < -OUTLINE_SLACK_PX:
                raise ValueError(f"{frame.name}: no detected block face holds the labelled pixel ({u:.0f}, {v:.0f}) "
                                 f"({colour}); {len(found)} faces were detected")
            colours.append(best[1].mean_rgb * best[1].white_balance)
            names.append(colour)
    return np.array(colours).reshape(-1, 3), names

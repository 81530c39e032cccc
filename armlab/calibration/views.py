"""Checkerboard photo sets on disk: a folder of grayscale JPEG views plus `checkerboard.json` (board geometry, image
size, view names, free notes). The same format holds the simulated set of data/checkerboard/ and a set photographed
with a real camera; nothing here knows which.

Record a set for a real camera (hold the board still in each of ~16 poses that tilt it up to ~40 deg and cover the
image, corners included) and save it:

    views = []
    for _ in range(16):
        input("pose the board, then press Enter")
        views.append(station.camera.capture().rgb)
    save_checkerboard_set(views, folder)

Views are stored as grayscale JPEG (quality 95): calibration only uses gray levels, and the sensor noise makes
lossless files ~450 KB per view against ~200 KB. Units: px (image size), mm (square edge).
"""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np

from armlab.calibration.intrinsics import check_pattern
from armlab.camera import MAX_IMAGE_SIDE_PX
from armlab.files import read_json, write_bytes_atomic, write_json_atomic
from armlab.images import check_gray_or_rgb, to_gray
from armlab.schemas import file_name, integer, number, strict_object, vector

__all__ = ["save_checkerboard_set", "load_checkerboard_set", "METADATA_FILE", "JPEG_QUALITY"]

METADATA_FILE = "checkerboard.json"
JPEG_QUALITY = 95


def save_checkerboard_set(images, folder, pattern_size: tuple[int, int] = (9, 6), square_mm: float = 25.0,
                          notes: dict | None = None) -> Path:
    """Save checkerboard views (uint8 gray (H, W) or RGB (H, W, 3), all one size) as view_NN.jpg and
    checkerboard.json in `folder` (created if needed). Every file is written atomically, the metadata last, so a
    failed save never leaves a set that loads with missing views. `notes`: extra JSON fields (e.g. the camera's
    serial number, the simulated truth). Returns the folder. Raises ValueError for bad images (nothing written)."""
    pattern_size, square_mm = check_pattern(pattern_size, square_mm)
    if isinstance(images, np.ndarray) and (images.ndim == 2 or (images.ndim == 3 and images.shape[2] == 3)):
        raise ValueError(f"images must be a list of images, got one array of shape {images.shape}")
    grays = [to_gray(check_gray_or_rgb(img, f"images[{i}]")) for i, img in enumerate(images)]
    if not grays:
        raise ValueError("save_checkerboard_set needs at least one image")
    size = grays[0].shape
    for i, g in enumerate(grays):
        if g.shape != size:
            raise ValueError(f"images[{i}] is {g.shape[1]}x{g.shape[0]}, the first is {size[1]}x{size[0]}")
    notes = dict(notes or {})
    reserved = {"pattern_size", "square_mm", "image_size", "images"} & set(notes)
    if reserved:
        raise ValueError(f"notes may not set {sorted(reserved)}: they describe the set itself")
    out = Path(folder)
    out.mkdir(parents=True, exist_ok=True)
    names = []
    for i, gray in enumerate(grays):
        ok, jpg = cv2.imencode(".jpg", gray, [cv2.IMWRITE_JPEG_QUALITY, JPEG_QUALITY])
        if not ok:
            raise RuntimeError(f"JPEG encoding of images[{i}] failed")
        names.append(f"view_{i:02d}.jpg")
        write_bytes_atomic(out / names[-1], jpg.tobytes())
    meta = {**notes, "pattern_size": list(pattern_size), "square_mm": square_mm,
            "image_size": [size[1], size[0]], "images": names}
    write_json_atomic(out / METADATA_FILE, meta)
    return out


SCHEMA = strict_object({
    "pattern_size": vector(integer(2, 1000), 2), "square_mm": number(exclusive_minimum=0.0, maximum=1e4),
    "image_size": vector(integer(1, MAX_IMAGE_SIDE_PX), 2), "images": vector(file_name(), min_items=1,
                                                                             max_items=10_000)},
    required=("pattern_size", "square_mm", "image_size", "images"), additional=True)
"""The declared schema of a checkerboard set's checkerboard.json (armlab.schemas); other keys are the set's notes."""


def load_checkerboard_set(folder) -> tuple[list[np.ndarray], dict]:
    """The views (grayscale (H, W) uint8 each) of a saved set and its metadata (checkerboard.json, with
    pattern_size, square_mm, image_size, images). Raises ValueError naming the file when the folder, the metadata or
    a view is missing or corrupt, or a view's size differs from image_size."""
    folder = Path(folder)
    meta_path = folder / METADATA_FILE
    if not folder.is_dir():
        raise ValueError(f"{folder}: no checkerboard set here (folder not found)")
    meta = read_json(meta_path, "checkerboard metadata", schema=SCHEMA)
    names = [str(n) for n in meta["images"]]
    pattern_size, square_mm = check_pattern(tuple(meta["pattern_size"]), float(meta["square_mm"]))
    width, height = (int(n) for n in meta["image_size"])
    images = []
    for name in names:
        img = cv2.imread(str(folder / name), cv2.IMREAD_GRAYSCALE)
        if img is None:
            raise ValueError(f"{folder / name}: missing or unreadable image")
        if img.shape != (height, width):
            raise ValueError(f"{folder / name}: {img.shape[1]}x{img.shape[0]} image in a {width}x{height} set")
        images.append(img)
    return images, {**meta, "pattern_size": list(pattern_size), "square_mm": square_mm}

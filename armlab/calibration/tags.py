"""AprilTag detection (pupil-apriltags) in OpenCV's pixel convention.

pupil-apriltags reports corners with the pixel centre at +0.5 (measured on rendered tags: 0.7 px off raw, 0.05 px
after the shift): they are shifted by -0.5 px here so they mix with OpenCV. Corner order: with the tag upright in
the image, bottom-left, bottom-right, top-right, top-left (counter-clockwise as seen), matching
armlab.lab.TagLayout.corners_world.

Decodes that needed bit corrections (hamming != 0) are dropped by default: on the simulated board a spurious id 509
turned up next to the dark arm, and a real board's four tags always decode exactly.
"""

from __future__ import annotations

import atexit
from dataclasses import dataclass

import numpy as np

from armlab.images import check_gray_or_rgb

__all__ = ["TagDetection", "detect_tags", "pupil_detector", "PUPIL_PIXEL_OFFSET"]

PUPIL_PIXEL_OFFSET = 0.5  # pupil-apriltags puts pixel centres at +0.5; OpenCV at 0


@dataclass(frozen=True)
class TagDetection:
    """One detected tag: id, corners (4, 2) px in OpenCV convention, centre (2,) px, decision margin, and the number
    of bits the decoder had to correct (hamming)."""

    tag_id: int
    corners: np.ndarray
    center: np.ndarray
    decision_margin: float
    hamming: int = 0


_DETECTORS: dict[tuple[str, float], object] = {}


def pupil_detector(family: str = "tag36h11", quad_decimate: float = 1.0):
    """The process-wide pupil-apriltags Detector for (family, decimation), kept for the life of the process.

    Use this rather than creating Detectors yourself: pupil-apriltags' Detector.__del__ crashes the interpreter
    (segfault or abort) now and then when a detector is garbage-collected; these are freed safely at exit.
    Its raw detections use pupil's pixel convention (centres at +0.5); detect_tags converts them.
    """
    key = (family, quad_decimate)
    if key not in _DETECTORS:
        from pupil_apriltags import Detector

        try:
            _DETECTORS[key] = Detector(families=family, quad_decimate=quad_decimate, refine_edges=1,
                                       decode_sharpening=0.25)
        except Exception as e:  # pupil-apriltags raises a bare error for unknown families
            raise ValueError(f"cannot make an AprilTag detector for family {family!r}: {e}") from None
    return _DETECTORS[key]


@atexit.register
def _release_detectors() -> None:
    """Free the detectors in the right order. pupil-apriltags' own __del__ frees the tag families before the detector
    that still points at them, which crashes the interpreter now and then at exit (segfault while
    garbage-collecting). Detector first, then its families; then __del__ has nothing left to do."""
    while _DETECTORS:
        det = _DETECTORS.popitem()[1]
        ptr = getattr(det, "tag_detector_ptr", None)
        if ptr is None:
            continue
        det.libc.apriltag_detector_destroy.restype = None
        det.libc.apriltag_detector_destroy(ptr)
        for family, tf in det.tag_families.items():
            destroy = getattr(det.libc, f"{family}_destroy")
            destroy.restype = None
            destroy(tf)
        det.tag_detector_ptr = None
        det.tag_families = {}


def detect_tags(image, family: str = "tag36h11", quad_decimate: float = 1.0,
                min_margin: float = 20.0, max_hamming: int = 0) -> list[TagDetection]:
    """AprilTags in a uint8 gray or RGB image, sorted by id.

    Weak decodes (decision margin < min_margin) and decodes that needed more than `max_hamming` corrected bits are
    dropped (default: exact decodes only). Corners and centres are in OpenCV pixels.
    """
    gray = np.ascontiguousarray(check_gray_or_rgb(image))
    if quad_decimate < 1:
        raise ValueError(f"quad_decimate must be >= 1, got {quad_decimate}")
    found = pupil_detector(family, float(quad_decimate)).detect(gray)
    out = [TagDetection(int(d.tag_id), np.asarray(d.corners, float) - PUPIL_PIXEL_OFFSET,
                        np.asarray(d.center, float) - PUPIL_PIXEL_OFFSET, float(d.decision_margin), int(d.hamming))
           for d in found if d.decision_margin >= min_margin and d.hamming <= max_hamming]
    return sorted(out, key=lambda d: d.tag_id)

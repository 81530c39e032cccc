"""AprilTag detection (pupil-apriltags) in OpenCV's pixel convention.

pupil-apriltags reports corners with the pixel centre at +0.5 (reference/toolchain.md): they are shifted by -0.5 px
here so they mix with OpenCV. Corner order: with the tag upright in the image, bottom-left, bottom-right, top-right,
top-left (counter-clockwise as seen), matching armlab.lab.TagLayout.corners_world.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np

from armlab.images import check_gray_or_rgb

__all__ = ["TagDetection", "detect_tags", "PUPIL_PIXEL_OFFSET"]

PUPIL_PIXEL_OFFSET = 0.5  # pupil-apriltags puts pixel centres at +0.5; OpenCV at 0


@dataclass(frozen=True)
class TagDetection:
    """One detected tag: id, corners (4, 2) px in OpenCV convention, centre (2,) px, decision margin."""

    tag_id: int
    corners: np.ndarray
    center: np.ndarray
    decision_margin: float


@functools.lru_cache(maxsize=8)
def _detector(family: str, quad_decimate: float):
    from pupil_apriltags import Detector

    return Detector(families=family, quad_decimate=quad_decimate, refine_edges=1, decode_sharpening=0.25)


def detect_tags(image, family: str = "tag36h11", quad_decimate: float = 1.0,
                min_margin: float = 20.0) -> list[TagDetection]:
    """AprilTags in a uint8 gray or RGB image, sorted by id; weak decodes (decision margin < min_margin) dropped."""
    gray = np.ascontiguousarray(check_gray_or_rgb(image))
    found = _detector(family, float(quad_decimate)).detect(gray)
    out = [TagDetection(int(d.tag_id), np.asarray(d.corners, float) - PUPIL_PIXEL_OFFSET,
                        np.asarray(d.center, float) - PUPIL_PIXEL_OFFSET, float(d.decision_margin))
           for d in found if d.decision_margin >= min_margin]
    return sorted(out, key=lambda d: d.tag_id)

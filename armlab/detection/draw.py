"""Annotate a camera image with detections: outlines, labels and yaw axes."""

from __future__ import annotations

import cv2
import numpy as np

from armlab.blocks import LAB_RGB
from armlab.images import check_rgb

__all__ = ["draw_detections"]


_FONT, _SCALE, _THICK = cv2.FONT_HERSHEY_SIMPLEX, 0.8, 4
_OFFSETS = [(12, -12), (12, 30), (-12, -12), (-12, 30), (12, -40), (12, 58), (-12, -40), (-12, 58)]   # px from u, v


def _label_origin(label: str, u: int, v: int, taken: list[tuple[int, int, int, int]], shape) -> tuple[int, int]:
    """The text origin for `label` next to (u, v) px: the first of _OFFSETS (right or left of the point, above or
    below it) whose box stays in the image and overlaps no box in `taken`, else the first; the box is added."""
    (w, h), base = cv2.getTextSize(label, _FONT, _SCALE, _THICK)
    first = None
    for du, dv in _OFFSETS:
        x = u + du if du > 0 else u + du - w
        box = (x, v + dv - h, x + w, v + dv + base)
        inside = box[0] >= 0 and box[1] >= 0 and box[2] < shape[1] and box[3] < shape[0]
        free = all(box[2] <= t[0] or t[2] <= box[0] or box[3] <= t[1] or t[3] <= box[1] for t in taken)
        first = first or box
        if inside and free:
            first = box
            break
    taken.append(first)
    return first[0], first[3] - base


def draw_detections(rgb, blocks, camera=None, axis_mm: float = 25.0) -> np.ndarray:
    """A copy of rgb (H, W, 3) uint8 with each block's contour, a "colour size" label and, with a camera, its yaw
    axes drawn from the top-face centre (x axis red, y axis green, `axis_mm` long). Labels are placed beside their
    block where they overlap no label drawn before (top to bottom)."""
    out = check_rgb(rgb).copy()
    taken: list[tuple[int, int, int, int]] = []
    for b in sorted(blocks, key=lambda b: (b.pixel[1], b.pixel[0])):
        bright = np.clip(np.array(LAB_RGB[b.color]) * 1.8, 0, 255)
        colour = (255, 255, 255) if b.shape != "cube" else tuple(int(c) for c in bright)
        if b.contour is not None:
            cv2.polylines(out, [b.contour.astype(np.int32).reshape(-1, 1, 2)], True, colour, 2, cv2.LINE_AA)
        u, v = (int(round(c)) for c in b.pixel)
        label = f"{b.color} {b.size}" if b.shape == "cube" else "distractor"
        origin = _label_origin(label, u, v, taken, out.shape)
        cv2.putText(out, label, origin, _FONT, _SCALE, (255, 255, 255), _THICK, cv2.LINE_AA)
        cv2.putText(out, label, origin, _FONT, _SCALE, (0, 0, 0), 2, cv2.LINE_AA)
        if camera is not None:
            c, s = np.cos(b.yaw), np.sin(b.yaw)
            ends = b.position + axis_mm * np.array([[c, s, 0.0], [-s, c, 0.0]])
            uv = camera.project(np.vstack([b.position, ends]))
            if np.all(np.isfinite(uv)):
                p0 = tuple(int(x) for x in np.rint(uv[0]))
                cv2.line(out, p0, tuple(int(x) for x in np.rint(uv[1])), (255, 0, 0), 2, cv2.LINE_AA)
                cv2.line(out, p0, tuple(int(x) for x in np.rint(uv[2])), (0, 200, 0), 2, cv2.LINE_AA)
    return out

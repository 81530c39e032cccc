"""Annotate a camera image with detections: outlines, labels and yaw axes."""

from __future__ import annotations

import cv2
import numpy as np

from armlab.blocks import LAB_RGB
from armlab.images import check_rgb

__all__ = ["draw_detections"]


def draw_detections(rgb, blocks, camera=None, axis_mm: float = 25.0) -> np.ndarray:
    """A copy of rgb (H, W, 3) uint8 with each block's contour, a "colour size" label and, with a camera, its yaw
    axes drawn from the top-face centre (x axis red, y axis green, `axis_mm` long)."""
    out = check_rgb(rgb).copy()
    for b in blocks:
        bright = np.clip(np.array(LAB_RGB[b.color]) * 1.8, 0, 255)
        colour = (255, 255, 255) if b.shape != "cube" else tuple(int(c) for c in bright)
        if b.contour is not None:
            cv2.polylines(out, [b.contour.astype(np.int32).reshape(-1, 1, 2)], True, colour, 2, cv2.LINE_AA)
        u, v = (int(round(c)) for c in b.pixel)
        label = f"{b.color} {b.size}" if b.shape == "cube" else "distractor"
        cv2.putText(out, label, (u + 12, v - 12), cv2.FONT_HERSHEY_SIMPLEX, 0.8, (255, 255, 255), 4, cv2.LINE_AA)
        cv2.putText(out, label, (u + 12, v - 12), cv2.FONT_HERSHEY_SIMPLEX, 0.8, (0, 0, 0), 2, cv2.LINE_AA)
        if camera is not None:
            c, s = np.cos(b.yaw), np.sin(b.yaw)
            ends = b.position + axis_mm * np.array([[c, s, 0.0], [-s, c, 0.0]])
            uv = camera.project(np.vstack([b.position, ends]))
            if np.all(np.isfinite(uv)):
                p0 = tuple(int(x) for x in np.rint(uv[0]))
                cv2.line(out, p0, tuple(int(x) for x in np.rint(uv[1])), (255, 0, 0), 2, cv2.LINE_AA)
                cv2.line(out, p0, tuple(int(x) for x in np.rint(uv[2])), (0, 200, 0), 2, cv2.LINE_AA)
    return out

"""Top faces of objects standing on the board, segmented from a height map.

Objects are pixels higher than `min_height_mm` above the board. Inside each connected object region, top faces are
flat plateaus: the heights of a horizontal face pile up in one histogram peak, while vertical side faces spread
evenly. Each peak's connected pixels form one candidate face — so a stack shows its top block's face, and a
lower block's face where it is still visible.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

__all__ = ["Face", "segment_faces"]


@dataclass(frozen=True)
class Face:
    """A flat top face: its pixel mask's bounding box (x, y, w, h), the mask inside it, and its height (mm)."""

    bbox: tuple[int, int, int, int]
    mask: np.ndarray
    height_mm: float

    def pixels(self) -> tuple[np.ndarray, np.ndarray]:
        """Row and column indices (in the full image) of the face's pixels."""
        r, c = np.nonzero(self.mask)
        return r + self.bbox[1], c + self.bbox[0]


def _plateau_levels(heights: np.ndarray, bin_mm: float, min_pixels: int) -> list[float]:
    """Heights (mm) of the histogram peaks that hold at least `min_pixels` pixels within +-1.5 bins."""
    lo, hi = float(heights.min()), float(heights.max())
    edges = np.arange(lo - bin_mm, hi + 2 * bin_mm, bin_mm)
    hist, edges = np.histogram(heights, edges)
    smooth = np.convolve(hist, [1, 2, 3, 2, 1], mode="same")
    levels = []
    for i in range(1, len(smooth) - 1):
        if smooth[i] >= smooth[i - 1] and smooth[i] > smooth[i + 1] and hist[max(0, i - 1):i + 2].sum() >= min_pixels:
            levels.append(0.5 * (edges[i] + edges[i + 1]))
    return levels


def segment_faces(height_mm: np.ndarray, valid: np.ndarray, min_height_mm: float = 10.0,
                  face_tolerance_mm: float = 6.0, min_face_pixels: int = 120) -> list[Face]:
    """Top faces in a height map (H, W) mm (NaN allowed) restricted to `valid` (H, W) bool pixels."""
    h = np.where(valid & np.isfinite(height_mm), height_mm, 0.0).astype(np.float32)
    h = cv2.medianBlur(h, 5)
    objects = (h > min_height_mm).astype(np.uint8)
    n, labels, stats, _ = cv2.connectedComponentsWithStats(objects, connectivity=4)
    faces: list[Face] = []
    for k in range(1, n):
        x, y, w, hh, area = stats[k]
        if area < min_face_pixels:
            continue
        sub_labels = labels[y:y + hh, x:x + w] == k
        sub_h = h[y:y + hh, x:x + w]
        for level in _plateau_levels(sub_h[sub_labels], 2.0, min_face_pixels // 2):
            on_level = (sub_labels & (np.abs(sub_h - level) < face_tolerance_mm)).astype(np.uint8)
            on_level = cv2.morphologyEx(on_level, cv2.MORPH_OPEN, np.ones((3, 3), np.uint8))
            m, face_labels, face_stats, _ = cv2.connectedComponentsWithStats(on_level, connectivity=4)
            for j in range(1, m):
                if face_stats[j, 4] < min_face_pixels:
                    continue
                fx, fy, fw, fh, _ = face_stats[j]
                mask = face_labels[fy:fy + fh, fx:fx + fw] == j
                face_heights = sub_h[fy:fy + fh, fx:fx + fw][mask]
                faces.append(Face((x + fx, y + fy, fw, fh), mask, float(np.median(face_heights))))
    return faces

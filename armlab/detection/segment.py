"""Top faces of objects standing on the board, segmented from a height map.

Objects are pixels higher than `min_height_mm` above the board. Inside each connected object region, top faces are
flat plateaus: the heights of a horizontal face pile up in one histogram peak, while vertical side faces spread
evenly. For each peak, the region's pixels at or above that height split into silhouettes; each silhouette with
enough pixels on the peak is one face. So a stack shows its top block's face, and a lower block's face where it is
still visible (the ring of a large block around a small one on top of it), and the face's silhouette includes what
stands on it.

A top face is level, a side face is not: a side face seen obliquely (far from the camera's nadir, where it covers
as much of the image as a top face) rises by its whole edge over a few rows, so a band of it can gather enough pixels
within the tolerance of one height to pass as a plateau (seed 2's large yellow block read as a second, small one at
22.7 mm next to it). Faces whose core's heights (within half the tolerance of the face's height) rise more than
`max_slope_mm` per sample in a plane fit are left out.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

__all__ = ["Face", "segment_faces"]

_KERNEL = np.ones((3, 3), np.uint8)


@dataclass(frozen=True)
class Face:
    """A flat top face: the bounding box (x, y, w, h) of its silhouette, its visible pixels (mask over the box),
    its height (mm), and the silhouette (mask over the box: the face plus whatever stands on it)."""

    bbox: tuple[int, int, int, int]
    mask: np.ndarray
    height_mm: float
    silhouette: np.ndarray | None = None

    def pixels(self) -> tuple[np.ndarray, np.ndarray]:
        """Row and column indices (in the full image) of the face's pixels."""
        r, c = np.nonzero(self.mask)
        return r + self.bbox[1], c + self.bbox[0]


def _median(values: np.ndarray) -> float:
    """np.median of a non-empty 1-d array without NaN (the same value, a fraction of the call's overhead)."""
    k = len(values) // 2
    if len(values) % 2:
        return float(np.partition(values, k)[k])
    part = np.partition(values, [k - 1, k])
    return float((part[k - 1] + part[k]) / 2)


def _plateau_levels(heights: np.ndarray, bin_mm: float, min_pixels: int) -> list[float]:
    """Heights (mm) of the histogram peaks that hold at least `min_pixels` pixels within +-1.5 bins."""
    lo = float(heights.min()) - bin_mm
    bins = ((heights - lo) / bin_mm).astype(np.intp)                   # bins [lo + i bin, lo + (i + 1) bin)
    hist = np.bincount(bins, minlength=int(bins.max()) + 3)             # and two empty bins above
    edges = lo + bin_mm * np.arange(len(hist) + 1)
    smooth = np.convolve(hist, [1, 2, 3, 2, 1], mode="same")
    inner = smooth[1:-1]
    peaks = np.flatnonzero((inner >= smooth[:-2]) & (inner > smooth[2:])) + 1
    window = np.convolve(hist, [1, 1, 1], mode="same")
    return [float(0.5 * (edges[i] + edges[i + 1])) for i in peaks if window[i] >= min_pixels]


def _slope(heights: np.ndarray, mask: np.ndarray) -> float:
    """How steeply (mm per sample) the least-squares plane through the heights (h, w) mm at the mask's pixels rises
    (0 for fewer than three pixels or pixels on one line): the normal equations in centred coordinates, a tenth of
    np.linalg.lstsq's cost."""
    r, c = np.nonzero(mask)
    if len(r) < 3:
        return 0.0
    z = heights[r, c].astype(float)
    r, c, z = r - r.mean(), c - c.mean(), z - z.mean()
    scc, srr, scr, scz, srz = c @ c, r @ r, c @ r, c @ z, r @ z
    det = scc * srr - scr * scr
    if det <= 1e-9 * scc * srr:
        return 0.0
    return float(np.hypot(srr * scz - scr * srz, scc * srz - scr * scz) / det)


def segment_faces(height_mm: np.ndarray, valid: np.ndarray, min_height_mm: float = 10.0,
                  face_tolerance_mm: float = 6.0, min_face_pixels: int = 120, median_px: int = 5,
                  max_slope_mm: float = 1.0) -> list[Face]:
    """Top faces in a height map (H, W) mm (NaN allowed) restricted to `valid` (H, W) bool pixels.

    min_face_pixels: fewest pixels of a face on its plateau (scale it with the map's resolution); median_px: the
    median filter's size (3 or 5) that removes the depth's speckle: it also erases parts of objects thinner than about
    half of it, so use 3 on a reduced map (an arch's legs are 3-4 samples wide at half resolution); max_slope_mm: the
    steepest a face's core may rise, mm per sample (scale it with the map's resolution: at half resolution a block's
    top face rises less than 0.3 mm per sample, 0.6 when the arm leaves only a few samples of it, a side face's band
    2)."""
    h = np.zeros(np.shape(height_mm), np.float32)
    np.copyto(h, height_mm, where=valid & np.isfinite(height_mm), casting="unsafe")
    h = cv2.medianBlur(h, median_px)
    objects = h > min_height_mm
    n, labels = cv2.connectedComponents(objects.view(np.uint8), connectivity=4)
    faces: list[Face] = []
    if n <= 1:
        return faces
    # boxes and areas from the object pixels only (a few percent of the map), without OpenCV's per-component
    # statistics (which cost 5x the labelling) or a pass over the whole label image
    idx = np.flatnonzero(objects)
    lab = labels.ravel()[idx]
    order = np.argsort(lab, kind="stable")
    areas = np.bincount(lab, minlength=n)
    rows, cols = np.divmod(idx[order], h.shape[1])
    starts = np.concatenate([[0], np.cumsum(areas[1:-1])])
    r0, r1 = np.minimum.reduceat(rows, starts), np.maximum.reduceat(rows, starts) + 1
    c0, c1 = np.minimum.reduceat(cols, starts), np.maximum.reduceat(cols, starts) + 1
    for k in range(1, n):
        if areas[k] < min_face_pixels:
            continue
        y, x = int(r0[k - 1]), int(c0[k - 1])
        hh, w = int(r1[k - 1]) - y, int(c1[k - 1]) - x
        region = labels[y:y + hh, x:x + w] == k
        sub_h = h[y:y + hh, x:x + w]
        for level in _plateau_levels(sub_h[region], 2.0, min_face_pixels // 2):
            on_level = (region & (np.abs(sub_h - level) < face_tolerance_mm)).astype(np.uint8)
            on_level = cv2.morphologyEx(on_level, cv2.MORPH_OPEN, _KERNEL).astype(bool)   # no thin side bands
            above = (region & (sub_h > level - face_tolerance_mm)).astype(np.uint8)
            m, parts, part_stats, _ = cv2.connectedComponentsWithStats(above, connectivity=4)
            counts = np.bincount(parts[on_level], minlength=m)
            for j in np.flatnonzero(counts >= min_face_pixels):
                if j == 0:
                    continue
                fx, fy, fw, fh, _ = part_stats[j]
                sil = parts[fy:fy + fh, fx:fx + fw] == j
                mask = sil & on_level[fy:fy + fh, fx:fx + fw]
                heights = sub_h[fy:fy + fh, fx:fx + fw]
                face_h = _median(heights[mask])
                # level? the plane fit of the face's core (within half the tolerance of its height): a top face's
                # pixels include a band of its own side faces within the tolerance, which tilts a fit of them all
                if _slope(heights, mask & (np.abs(heights - face_h) <= 0.5 * face_tolerance_mm)) > max_slope_mm:
                    continue                                    # a band of a side face
                faces.append(Face((int(x + fx), int(y + fy), int(fw), int(fh)), mask, face_h, sil))
    return faces

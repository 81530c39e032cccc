"""Many small boxes processed by one OpenCV call each: pack them side by side into one image (an atlas), each inside
a one-pixel rim that keeps their pixels apart and reproduces OpenCV's image border for each box, and map flat lists
of their pixels into it. segment_faces opens and labels every (object region, plateau level) box this way.

Integers are pixels; boxes are (top, left, heights, widths) arrays (B,).
"""

from __future__ import annotations

import cv2
import numpy as np

__all__ = ["runs", "grouped", "pack_boxes", "rims", "open_each_box"]

_KERNEL = np.ones((3, 3), np.uint8)


def runs(starts: np.ndarray, lengths: np.ndarray) -> np.ndarray:
    """The integer runs starts[i], starts[i] + 1, ..., starts[i] + lengths[i] - 1, end to end (lengths >= 0)."""
    ends = np.cumsum(lengths)
    return np.arange(int(ends[-1]) if len(ends) else 0) + np.repeat(starts - (ends - lengths), lengths)


def pack_boxes(heights: np.ndarray, widths: np.ndarray) -> tuple[np.ndarray, np.ndarray, tuple[int, int]]:
    """Places rectangles (B,) pixels high and wide side by side in shelves of an atlas (tallest first, so little is
    wasted), none overlapping. Returns their top rows (B,), left columns (B,) and the atlas's (height, width)."""
    hs, ws = heights.tolist(), widths.tolist()
    width = max(max(ws), int(np.ceil(np.sqrt(float(np.dot(heights, widths))))))
    top, left = [0] * len(hs), [0] * len(hs)
    x = y = shelf = 0
    for b in sorted(range(len(hs)), key=lambda b: -hs[b]):
        if x + ws[b] > width:
            x, y, shelf = 0, y + shelf, 0
        top[b], left[b] = y, x
        x, shelf = x + ws[b], max(shelf, hs[b])
    return np.array(top, np.intp), np.array(left, np.intp), (y + shelf, width)


def rims(top: np.ndarray, left: np.ndarray, heights: np.ndarray, widths: np.ndarray, width: int) -> np.ndarray:
    """Flat indices, in an image `width` pixels wide, of the one-pixel rims of rectangles (B,) (top, left, heights,
    widths pixels, all >= 3)."""
    cols, rows = runs(left, widths), runs(top + 1, heights - 2)
    sides = rows * width + np.repeat(left, heights - 2)
    return np.concatenate([np.repeat(top * width, widths) + cols, np.repeat((top + heights - 1) * width, widths) + cols,
                           sides, sides + np.repeat(widths - 1, heights - 2)])


def open_each_box(atlas: np.ndarray, rim: np.ndarray) -> np.ndarray:
    """cv2.MORPH_OPEN (3 x 3) of each box of an atlas (uint8 0/1 pixels, each box inside a one-pixel rim: `rim`,
    flat indices, 0 in the atlas) as if the box were an image of its own: OpenCV's erosion and dilation leave an
    image's border out, so the rims are 1 for the erosion (which takes minima) and 0 for the dilation (maxima).
    Returns the opened atlas (uint8 0/1) inside the boxes (the rims hold anything); `atlas` is left as it was."""
    flat = atlas.reshape(-1)
    flat[rim] = 1
    eroded = cv2.erode(atlas, _KERNEL)
    flat[rim] = 0
    eroded.reshape(-1)[rim] = 0
    return cv2.dilate(eroded, _KERNEL)


def grouped(keys: np.ndarray, n_keys: int) -> np.ndarray:
    """A stable argsort of non-negative int keys below n_keys (a radix sort of 16-bit keys when they fit)."""
    return np.argsort(keys.astype(np.uint16) if n_keys <= 1 << 16 else keys, kind="stable")

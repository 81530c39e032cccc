"""The image printed on the lab's board (grid lines, AprilTags) and the table around it, as a texture in world mm.

The texture covers the table plane z = 0 around the board; texel (col, row) has its centre at world
x = x0 + (col + 0.5) * s, y = y1 - (row + 0.5) * s (rows run towards -y, so the texture looks like the board seen from
above with +y up). AprilTags are tag36h11 drawn with OpenCV, turned 180 deg to the official layout (OpenCV's images
are rotated against it), on a white paper square; their black squares match `TagLayout.corners_world` exactly.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import cv2
import numpy as np

from armlab.lab import LabConfig, lab_config

__all__ = ["BoardTexture", "board_texture", "tag_image", "BOARD_RGB", "TABLE_RGB", "GRID_RGB"]

BOARD_RGB = (196, 192, 182)      # light grey board
GRID_RGB = (70, 70, 72)          # printed grid lines
TABLE_RGB = (112, 92, 70)        # wooden table around the board
GRID_LINE_MM = 1.5
TAG_MARGIN_CELLS = 2             # white paper around each tag's black square, in tag cells


@dataclass(frozen=True)
class BoardTexture:
    """An RGB texture (H, W, 3) uint8 of the plane z = 0 and `H_world_texel` (3, 3): texel (col, row, 1) ->
    world (x, y, 1) mm."""

    image: np.ndarray
    H_world_texel: np.ndarray
    mm_per_texel: float


def tag_image(family: str, tag_id: int, side_px: int) -> np.ndarray:
    """The black square of an AprilTag (side_px, side_px) uint8 in the official orientation (tag36h11 only)."""
    if family != "tag36h11":
        raise ValueError(f"cannot draw AprilTag family {family!r}: OpenCV draws tag36h11 only")
    if side_px % 8:
        raise ValueError(f"side_px must be a multiple of 8 (the tag has 8 cells), got {side_px}")
    dictionary = cv2.aruco.getPredefinedDictionary(cv2.aruco.DICT_APRILTAG_36h11)
    img = cv2.aruco.generateImageMarker(dictionary, int(tag_id), side_px, borderBits=1)
    return np.ascontiguousarray(np.rot90(img, 2))


def _texture(lab: LabConfig, mm_per_texel: float, extent_mm: tuple[float, float, float, float]) -> BoardTexture:
    x0, x1, y0, y1 = extent_mm
    s = mm_per_texel
    W, H = round((x1 - x0) / s), round((y1 - y0) / s)
    img = np.empty((H, W, 3), np.uint8)
    img[:] = TABLE_RGB

    def col(x):  # texel column edge of world x
        return (x - x0) / s

    def row(y):
        return (y1 - y) / s

    bx0, bx1 = round(col(lab.board_x[0])), round(col(lab.board_x[1]))
    by0, by1 = round(row(lab.board_y[1])), round(row(lab.board_y[0]))
    img[by0:by1, bx0:bx1] = BOARD_RGB
    half = GRID_LINE_MM / 2 / s
    xs = np.arange(lab.grid_x[0], lab.grid_x[1] + lab.grid_mm / 2, lab.grid_mm)
    ys = np.arange(lab.grid_y[0], lab.grid_y[1] + lab.grid_mm / 2, lab.grid_mm)
    for x in xs:
        c = col(x)
        img[by0:by1, max(round(c - half), bx0):min(round(c + half), bx1)] = GRID_RGB
    for y in ys:
        r = row(y)
        img[max(round(r - half), by0):min(round(r + half), by1), bx0:bx1] = GRID_RGB
    # tags: the black square is exactly size_mm wide (area-resampled from a fine drawing), on white paper
    tag_px = lab.tags.size_mm / s
    if abs(tag_px - round(tag_px)) > 1e-6:
        raise ValueError(f"the tag size {lab.tags.size_mm} mm must be a whole number of texels of {s} mm")
    tag_px = round(tag_px)
    margin = round(TAG_MARGIN_CELLS * tag_px / 8)
    for tag_id, (cx, cy) in lab.tags.centres_mm.items():
        fine = tag_image(lab.tags.family, tag_id, 8 * 32)
        square = cv2.resize(fine, (tag_px, tag_px), interpolation=cv2.INTER_AREA)
        c0, r0 = round(col(cx - lab.tags.size_mm / 2)), round(row(cy + lab.tags.size_mm / 2))
        img[r0 - margin:r0 + tag_px + margin, c0 - margin:c0 + tag_px + margin] = 255
        img[r0:r0 + tag_px, c0:c0 + tag_px] = square[..., None]
    # a texel centre is half a texel in from its edges
    H_world_texel = np.array([[s, 0, x0 + s / 2], [0, -s, y1 - s / 2], [0, 0, 1]])
    return BoardTexture(img, H_world_texel, s)


@functools.lru_cache(maxsize=2)
def board_texture(mm_per_texel: float = 0.5) -> BoardTexture:
    """The default lab's board on its table (cached): board, grid and tags from `lab_config()`, table 400 mm beyond."""
    lab = lab_config()
    extent = (lab.board_x[0] - 400, lab.board_x[1] + 400, lab.board_y[0] - 400, lab.board_y[1] + 400)
    tex = _texture(lab, mm_per_texel, extent)
    # lightly pre-filter so that bilinear sampling at ~1 mm per pixel does not alias the fine print
    return BoardTexture(cv2.GaussianBlur(tex.image, (0, 0), 1.0), tex.H_world_texel, tex.mm_per_texel)

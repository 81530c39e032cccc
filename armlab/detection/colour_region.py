"""A face's pixels by colour: the depth-seeded face grown or trimmed to the pixels of its core colour, the board's
white balance, the arm's dark grey. Works on the full-resolution image around each face segment.py found; the
result (ColourRegion) is what the square fit and the edge refinement measure. Units: pixels, mm (heights).
"""

from __future__ import annotations

from typing import NamedTuple

import cv2
import numpy as np

from armlab.detection.color import white_balance_gains
from armlab.detection.heightmap import world_coefficients
from armlab.detection.segment import Face

__all__ = ["FrameData", "ColourRegion", "refine_by_colour", "board_white_balance", "arm_coloured",
           "FACE_COLOR_LEVEL", "STANDING_RISE_MM", "BELOW_FACE_MM", "OCCLUDER_RISE_MM", "STANDING_KERNEL",
           "ARM_MAX_LEVEL", "ARM_MAX_CHROMA"]


class FrameData:
    """Per-frame data shared by the faces: images, the camera's per-pixel world rays, the arm mask (reduced
    resolution) and the reduction step."""

    def __init__(self, rgb, depth, camera, arm_small, step):
        self.rgb, self.depth, self.camera, self.arm_small, self.step = rgb, depth, camera, arm_small, step
        self.kz = world_coefficients(camera)[2]
        self.tz = np.float32(camera.T_world_cam[2, 3])

_SUM3 = np.ones((1, 3))                     # cv2.transform: the sum of three channels
_DIAG3 = np.diag_indices(3)
SQUARE3, SQUARE5, SQUARE7 = (np.ones((k, k), np.uint8) for k in (3, 5, 7))   # morphology kernels
STANDING_RISE_MM = 3.0    # a pixel not of a face's colour this far above it is something standing on the face
FACE_COLOR_LEVEL = 3.5    # a pixel this near the face's core colour (distance in core spreads) has the face's colour
BELOW_FACE_MM = 10.0      # a pixel this far below a face's height is not on it (the board, a lower face)
OCCLUDER_RISE_MM = 8.0    # a pixel this far above a face's height hides it (the arm, a block standing over it)
STANDING_KERNEL = np.ones((9, 9), np.uint8)   # outline points within 4 px of such a pixel are not the face's edge
ARM_MAX_LEVEL = 110    # the RX200 is black: its pixels are dark (max channel below this, 8-bit) ...
ARM_MAX_CHROMA = 22    # ... and grey (max - min channel below this), unlike every block colour's top face


class ColourRegion(NamedTuple):
    """A face's pixels by colour, in a patch of the image around it: mask (uint8, the face), origin (x0, y0) px of
    the patch, mean_rgb (3,) the core's mean colour, occluder (bool: pixels clearly above the face, what stands on it
    or the arm), standing (bool: the foot of what stands on it, above it by more than STANDING_RISE_MM, not of its
    colour) and distance (float32: the colour distance to the core colour in core spreads)."""

    mask: np.ndarray
    origin: tuple[int, int]
    mean_rgb: np.ndarray
    occluder: np.ndarray
    standing: np.ndarray
    distance: np.ndarray


def arm_coloured(rgb: np.ndarray) -> np.ndarray:
    """(H, W) bool: pixels dark and grey enough to be the arm (used only inside the arm's projected mask)."""
    r, g, b = rgb[..., 0], rgb[..., 1], rgb[..., 2]
    hi = np.maximum(np.maximum(r, g), b)       # element-wise: far faster than a reduction over the last axis
    lo = np.minimum(np.minimum(r, g), b)
    return (hi < ARM_MAX_LEVEL) & (hi - lo < ARM_MAX_CHROMA)


def board_white_balance(rgb: np.ndarray, height_small: np.ndarray, valid: np.ndarray, step: int) -> np.ndarray:
    """Gains from the board's own pixels (flat, near z = 0), sampled sparsely."""
    h = height_small[::4, ::4]
    with np.errstate(invalid="ignore"):
        sample = valid[::4, ::4] & (h < 4.0) & (h > -4.0)
    n = int(np.count_nonzero(sample))
    if n < 100:
        return np.ones(3)
    # the printed grid and tags are dark: use the bright majority of the board (brightness R + G + B at or above
    # its 40th percentile, linearly interpolated as numpy's percentile)
    sub = rgb[::4 * step, ::4 * step].astype(np.float32)
    total = cv2.transform(sub, _SUM3)
    values = total[sample]
    q = 0.4 * (n - 1)
    lo = int(q)
    hi = min(lo + 1, n - 1)
    part = np.partition(values, [lo, hi])
    threshold = part[lo] + (q - lo) * (part[hi] - part[lo])
    bright = (sample & (total >= threshold)).view(np.uint8)
    return white_balance_gains(np.array(cv2.mean(sub, mask=bright)[:3]))


def _fill_dropouts(height: np.ndarray, no_return: np.ndarray, face_coloured: np.ndarray, face_mm: float) -> None:
    """Heights (mm, in place) for a patch's pixels without a depth return: the face's own height (neither below nor
    above it: a dark face's dropouts, the band along its own edge), except where the nearest return is a surface of
    the face's colour clearly below it (BELOW_FACE_MM): a lower block of the same colour under the face, whose
    visible ring would otherwise join the face across the dropout band at the upper block's edge. Those take the
    nearest return's height."""
    lower = face_coloured & (height < face_mm - BELOW_FACE_MM)      # (a pixel without a return compares False)
    if lower.any():
        holes = np.flatnonzero(no_return)
        if len(holes):
            _, nearest = cv2.distanceTransformWithLabels(no_return.view(np.uint8), cv2.DIST_L2, 3,
                                                         labelType=cv2.DIST_LABEL_PIXEL)
            source = np.flatnonzero(~no_return)[nearest.ravel()[holes] - 1]   # labels: the returns in raster order
            flat = height.ravel()                                            # a view: height is contiguous
            flat[holes] = np.where(lower.ravel()[source], flat[source], np.float32(face_mm))
    cv2.patchNaNs(height, face_mm)


def refine_by_colour(face: Face, f: FrameData, pad: int = 6) -> ColourRegion:
    """The face's full-resolution pixels by colour. The top face is evenly lit and brighter than the shaded sides, so
    pixels near the depth-seeded face whose colour matches the face's core colour, and that are not clearly below
    the face, form the face (ColourRegion: the mask, the patch's origin, the core's mean colour, what occludes the
    face or stands on it, and the colour distance to the core)."""
    s = f.step
    x, y, w, h = (v * s for v in face.bbox)
    H, W = f.depth.shape
    x0, y0, x1, y1 = max(0, x - pad), max(0, y - pad), min(W, x + w + pad), min(H, y + h + pad)
    seed = np.zeros((y1 - y0, x1 - x0), np.uint8)
    big = face.mask.view(np.uint8)
    if s > 1:
        big = cv2.resize(big, None, fx=s, fy=s, interpolation=cv2.INTER_NEAREST)   # each sample becomes s x s
    seed[y - y0:y - y0 + big.shape[0], x - x0:x - x0 + big.shape[1]] = big[:y1 - y, :x1 - x]
    core = cv2.erode(seed, SQUARE7)
    rgb = f.rgb[y0:y1, x0:x1]
    if cv2.countNonZero(core) >= 20:
        mean, spread = (v.ravel() for v in cv2.meanStdDev(rgb, mask=core))
    else:
        # a thin face (the ring of a block under a smaller one): no core survives the erosion and the seed's pixels
        # mix in the neighbours' colours (the block on it, the face's own shaded sides), so the colour is the seed's
        # median and the spread its median absolute deviation (as a standard deviation)
        pixels = rgb[seed.view(bool)].astype(np.float32)
        mean = np.median(pixels, axis=0)
        spread = 1.4826 * np.median(np.abs(pixels - mean), axis=0)
    spread = np.maximum(spread, 4.0)
    # the colour distance in core spreads: one affine transform per channel, then the root of the squares' sum
    affine = np.zeros((3, 4))
    affine[_DIAG3] = 1 / spread
    affine[:, 3] = -mean / spread
    scaled = cv2.transform(rgb.astype(np.float32), affine)
    distance = cv2.sqrt(cv2.transform(np.multiply(scaled, scaled, out=scaled), _SUM3))
    away = distance >= FACE_COLOR_LEVEL
    height = np.multiply(f.depth[y0:y1, x0:x1], f.kz[y0:y1, x0:x1])
    height += f.tz
    no_return = np.isnan(height)
    _fill_dropouts(height, no_return, ~away, face.height_mm)
    height = cv2.medianBlur(height, 5)
    not_below = height > face.height_mm - BELOW_FACE_MM
    occluder = height > face.height_mm + OCCLUDER_RISE_MM
    if f.arm_small is not None:
        arm = f.arm_small[(y0 // s):(y1 + s - 1) // s, (x0 // s):(x1 + s - 1) // s]
        if arm.any():
            if s > 1:
                arm = cv2.resize(arm.view(np.uint8), None, fx=s, fy=s, interpolation=cv2.INTER_NEAREST)
            arm = arm.view(bool)[y0 % s:, x0 % s:][:y1 - y0, :x1 - x0]
            # the arm's dark grey is never the face; it hides the face where it is above it (occluder, from the
            # heights) or where it gave no return (unless the pixel has the face's colour: a dark face's dropouts)
            arm = arm & arm_coloured(rgb)
            not_below &= ~arm
            occluder |= arm & no_return & away
    candidate = (~away & not_below).view(np.uint8)     # bool as 0 / 1, no copy
    # what stands on the face: pixels not of its colour that rise above it (a block's side faces rise from the face,
    # so they are above it by less than `occluder` asks right next to it)
    standing = (height > face.height_mm + STANDING_RISE_MM) & ~occluder & away
    n, labels = cv2.connectedComponents(candidate, connectivity=4)
    if n <= 1:
        return ColourRegion(seed, (x0, y0), mean, occluder, standing, distance)
    overlap = np.bincount(labels[seed.view(bool)], minlength=n)
    overlap[0] = 0
    mask = (labels == int(np.argmax(overlap))).view(np.uint8)
    return ColourRegion(cv2.morphologyEx(mask, cv2.MORPH_CLOSE, SQUARE3), (x0, y0), mean, occluder, standing,
                        distance)

"""Is this frame what detection thinks it is? Two checks where a silent answer would mislead.

- The board is in the colour image: the pixels the depth puts on the board plane must look like a board (bright
  enough, not saturated, mostly uniform (a printed grid and tags on a plain board) but not one flat colour (a
  camera's image has noise, shading and the grid). An all-black, all-white, one-colour or noise image over a real
  depth frame is not a view of the board; detection then reports no blocks (and says why).
- The colours are RGB, not BGR: after the board's own white balance, the cubes' colours fit the colour model's six
  classes far better with red and blue swapped. Yellow and orange swap into colours no block has (cyan, azure), so a
  BGR frame with any of them is told apart from a colour cast (which the white balance removes, a swap it cannot).
  A frame of only red, blue, green and violet blocks reads plausibly either way and passes.

Units: 8-bit colour levels; the model's normalised distances (ColorModel.distances).
"""

from __future__ import annotations

import numpy as np

__all__ = ["BOARD_MIN_LEVEL", "BOARD_MAX_LEVEL", "BOARD_MIN_SPREAD", "BOARD_MAX_SPREAD", "BGR_FIT_RATIO", "NotRGBError",
           "board_problem", "bgr_problem"]

BOARD_MIN_LEVEL = 20.0        # mean brightness (0-255) below which the board's pixels are not lit: no board seen
BOARD_MAX_LEVEL = 250.0       # above which they are saturated: no board seen
BOARD_MIN_SPREAD = 1.0        # below it the board's pixels are one flat colour: a filled image, not a camera's
BOARD_MAX_SPREAD = 35.0       # largest channel's median absolute deviation (levels) on the board: a board is plain
                              # (12-15 on the simulator's realistic frames; uniform noise: 64)
BGR_FIT_RATIO = 0.5           # the cubes' summed distance to the model with red and blue swapped, over as read
_MIN_BOARD_SAMPLES = 100


class NotRGBError(ValueError):
    """The colour image looks like BGR (OpenCV's order): convert it with cv2.cvtColor(img, cv2.COLOR_BGR2RGB)."""


def board_problem(rgb_small: np.ndarray, board_small: np.ndarray) -> str | None:
    """Why the sampled colour pixels rgb_small (h, w, 3) uint8 over the board's sampled pixels board_small (h, w)
    bool (flat, at the board's height by the depth) do not show a board, or None when they may. Too few board
    samples to tell: None."""
    values = rgb_small[board_small].astype(np.float32)
    if len(values) < _MIN_BOARD_SAMPLES:
        return None
    level = values.mean(axis=1)
    mean = float(level.mean())
    if mean < BOARD_MIN_LEVEL:
        return f"the board's pixels are dark (mean level {mean:.0f} of 255): no board in the colour image"
    if mean > BOARD_MAX_LEVEL:
        return f"the board's pixels are saturated (mean level {mean:.0f} of 255): no board in the colour image"
    spread = float(np.median(np.abs(values - np.median(values, axis=0)), axis=0).max())
    if spread < BOARD_MIN_SPREAD:
        return (f"the board's pixels are all one colour ({spread:.1f} levels of spread): a plain image, not a "
                f"camera's view of the board")
    if spread > BOARD_MAX_SPREAD:
        return (f"the board's pixels vary by {spread:.0f} levels (median absolute deviation of a channel; a "
                f"board's: under {BOARD_MAX_SPREAD:.0f}): noise, or not the board, in the colour image")
    return None


def bgr_problem(balanced_rgb: np.ndarray, distances) -> str | None:
    """Why white-balanced mean colours (N, 3) of the cube faces say the image is BGR, or None. `distances` maps
    colours (N, 3) to the model's distances (N, K) (ColorModel.distances)."""
    x = np.asarray(balanced_rgb, float).reshape(-1, 3)
    if len(x) == 0:
        return None
    as_read = distances(x).min(axis=1)
    swapped = distances(x[:, ::-1]).min(axis=1)
    if swapped.sum() < BGR_FIT_RATIO * as_read.sum():
        return (f"the cubes' colours fit the colour model {as_read.sum() / max(swapped.sum(), 1e-9):.1f}x better "
                f"with red and blue swapped ({len(x)} faces): the image looks like BGR (OpenCV's order); pass RGB, "
                f"e.g. cv2.cvtColor(image, cv2.COLOR_BGR2RGB)")
    return None

"""Is this frame what detection thinks it is? Two checks where a silent answer would mislead.

- The board is in the colour image: the pixels the depth puts on the board plane must look like a camera's image
  of a board (bright enough, not saturated, not one flat colour, and changing little from one pixel to the next,
  as an image of a scene does and noise does not). An all-black, all-white, one-colour or noise image over a real
  depth frame is not a view of the board; detection then reports no blocks (and says why).
- The colours are RGB, not BGR: after the board's own white balance, the cubes' colours fit the colour model's six
  classes far better with red and blue swapped. Yellow and orange swap into colours no block has (cyan, azure), so a
  BGR frame with any of them is told apart from a colour cast (which the white balance removes, a swap it cannot).
  A frame of only red, blue, green and violet blocks reads plausibly either way and passes.

Units: 8-bit colour levels; the model's normalised distances (ColorModel.common_distances).
"""

from __future__ import annotations

import numpy as np

__all__ = ["BOARD_MIN_LEVEL", "BOARD_MAX_LEVEL", "BOARD_MAX_NEIGHBOUR_STEP", "BGR_FIT_RATIO", "NotRGBError",
           "board_problem", "bgr_problem"]

BOARD_MIN_LEVEL = 20.0        # mean brightness (0-255) below which the board's pixels are not lit: no board seen
BOARD_MAX_LEVEL = 250.0       # above which they are saturated: no board seen
BOARD_MAX_NEIGHBOUR_STEP = 30.0   # median difference (levels) between a board pixel and the one to its right: an
                                  # image of a scene changes little from pixel to pixel (3 on the simulator's
                                  # frames, depth corrected or not), uniform noise 75
BGR_FIT_RATIO = 0.5           # the cubes' summed distance to the model with red and blue swapped, over as read
_MIN_BOARD_SAMPLES = 100


class NotRGBError(ValueError):
    """The colour image looks like BGR (OpenCV's order): convert it with cv2.cvtColor(img, cv2.COLOR_BGR2RGB)."""


def board_problem(rgb_small: np.ndarray, right_small: np.ndarray, board_small: np.ndarray) -> str | None:
    """Why the sampled colour pixels rgb_small (h, w, 3) uint8 over the board's sampled pixels board_small (h, w)
    bool (flat, at the board's height by the depth) do not show a board, or None when they may. right_small: the
    pixels one to the right of each sample (h, w, 3). Too few board samples to tell: None."""
    if int(np.count_nonzero(board_small)) < _MIN_BOARD_SAMPLES:
        return None
    values = rgb_small[board_small].astype(np.int16)
    mean = float(values.mean())
    if mean < BOARD_MIN_LEVEL:
        return f"the board's pixels are dark (mean level {mean:.0f} of 255): no board in the colour image"
    if mean > BOARD_MAX_LEVEL:
        return f"the board's pixels are saturated (mean level {mean:.0f} of 255): no board in the colour image"
    if int(np.ptp(values, axis=0).max()) == 0:
        return "the board's pixels are all one colour: a filled image, not a camera's view of the board"
    step = float(np.median(np.abs(values - right_small[board_small].astype(np.int16)), axis=0).max())
    if step > BOARD_MAX_NEIGHBOUR_STEP:
        return (f"neighbouring pixels on the board differ by {step:.0f} levels (median; a camera's image of the "
                f"board: a few): noise, not a view of the board")
    return None


def bgr_problem(balanced_rgb: np.ndarray, distances) -> str | None:
    """Why white-balanced mean colours (N, 3) of the cube faces say the image is BGR, or None. `distances` maps
    colours (N, 3) to the model's distances (N, K) (ColorModel.common_distances)."""
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

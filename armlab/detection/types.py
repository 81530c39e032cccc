"""The detector's result and settings: Block (one detected top face) and DetectionSettings (its thresholds).

Units: mm and rad, world (board) frame; pixels (u right, v down).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

__all__ = ["Block", "DetectionSettings"]


@dataclass(frozen=True)
class Block:
    """A detected object's top face.

    color: one of the six block colours (nearest class), size: "large" or "small", position: (3,) world mm of the
    top-face centre, yaw: rad in [-pi/4, pi/4), pixel: (u, v) of the face centre, edge_mm: measured edge,
    shape: "cube" or "distractor", levels: how many blocks high the stack under this face is (top z / edge),
    color_margin: how clearly the colour won (larger is surer), contour: (K, 2) image outline of the face,
    mean_rgb: (3,) the face's mean colour as recorded, white_balance: (3,) the frame's gains from the board (the
    colour model classifies mean_rgb * white_balance).
    """

    color: str
    size: str
    position: np.ndarray
    yaw: float
    pixel: tuple[float, float]
    edge_mm: float
    shape: str = "cube"
    levels: int = 1
    color_margin: float = 0.0
    contour: np.ndarray = field(default=None, repr=False)
    mean_rgb: np.ndarray = field(default=None, repr=False)
    white_balance: np.ndarray = field(default=None, repr=False)

    @property
    def is_block(self) -> bool:
        return self.shape == "cube"


@dataclass(frozen=True)
class DetectionSettings:
    """Thresholds (mm unless noted). min_height: objects rise at least this above the board (half a small cube);
    max_height: higher pixels are the arm or a hand; size_split: edges above are "large" (25 vs 38 mm cubes);
    cube_edge_range: plausible cube edges; min_rectangularity: face area / its minimum rectangle (a square is 1,
    a disc 0.79, a triangle 0.5); max_aspect: longest / shortest side of a cube face; board_margin: ignore this
    much of the board's border; level_tolerance: a face's height must be within this of a stack of the lab's
    pieces (sums of the block edges), which rejects the oblique side faces near the image border;
    edge_tolerance: a cube's measured edge is within this of one of the lab's block edges;
    max_levels: the tallest stack (blocks) a face may top: faces at no height of such a stack are not reported,
    so raise it (and max_height) for towers (the "to the sky" event);
    max_face_slope: a top face's core (its pixels within 3 mm of its height) rises less than this in a plane fit
    (mm per full-resolution pixel; the band of a side face seen obliquely that passed as a face rose 1 mm per pixel,
    block tops rise less than 0.15, 0.3 when the arm leaves only a few of their pixels);
    min_face_pixels: fewest full-resolution pixels of a face (80: a small triangle or arch, 25 mm, far out on the
    board keeps fewer than 120 once the segmentation's median and opening have taken its corners and legs); step:
    segmentation works on every step-th pixel (each face is then measured at full resolution)."""

    min_height: float = 10.0
    max_height: float = 260.0
    size_split: float = 31.5
    cube_edge_range: tuple[float, float] = (19.0, 46.0)
    min_rectangularity: float = 0.8
    max_aspect: float = 1.15
    board_margin: float = 5.0
    min_face_pixels: int = 80
    max_face_slope: float = 0.5
    step: int = 2
    level_tolerance: float = 4.0
    edge_tolerance: float = 4.0
    max_levels: int = 6

    def __post_init__(self):
        if not isinstance(self.max_levels, int) or self.max_levels < 1:
            raise ValueError(f"DetectionSettings.max_levels must be a positive integer, got {self.max_levels!r}")
        if not isinstance(self.step, int) or self.step < 1:
            raise ValueError(f"DetectionSettings.step must be a positive integer, got {self.step!r}")
        if not self.max_face_slope > 0:
            raise ValueError(f"DetectionSettings.max_face_slope must be positive (mm per pixel), got "
                             f"{self.max_face_slope!r}")
        if not 0 < self.min_height < self.max_height:
            raise ValueError(f"DetectionSettings needs 0 < min_height < max_height, got {self.min_height}, "
                             f"{self.max_height}")

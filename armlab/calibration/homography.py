"""Top-down views of the board: the lab report's four-tag homography, and a distortion-aware rectification.

A top-down view maps board coordinates (x, y) mm on z = 0 to view pixels: column = (x - x_min) / mm_per_px,
row = (y_max - y) / mm_per_px (far side of the board at the top).
"""

from __future__ import annotations

import cv2
import numpy as np

from armlab.calibration.tags import TagDetection
from armlab.camera import Camera
from armlab.exercises.fallback import reference_fallback
from armlab.images import check_rgb
from armlab.lab import TagLayout, lab_config

__all__ = ["BoardView", "tag_homography"]


class BoardView:
    """A top-down image of the board at `mm_per_px` resolution, made from camera images.

    Args:
        camera: the calibrated camera (intrinsics, distortion, extrinsic).
        mm_per_px: view resolution.
        x_range, y_range: board extent shown (mm); default: the lab board.
    """

    def __init__(self, camera: Camera, mm_per_px: float = 1.0, x_range=None, y_range=None):
        cfg = lab_config()
        if mm_per_px <= 0:
            raise ValueError(f"mm_per_px must be positive, got {mm_per_px}")
        self.camera = camera
        self.mm_per_px = float(mm_per_px)
        self.x_range = tuple(x_range or cfg.board_x)
        self.y_range = tuple(y_range or cfg.board_y)
        self.width = int(round((self.x_range[1] - self.x_range[0]) / mm_per_px))
        self.height = int(round((self.y_range[1] - self.y_range[0]) / mm_per_px))
        cols, rows = np.meshgrid(np.arange(self.width), np.arange(self.height))
        xy = self.to_world(np.column_stack([cols.ravel(), rows.ravel()]))
        uv = camera.project(np.column_stack([xy, np.zeros(len(xy))]))
        self._map_u = uv[:, 0].reshape(self.height, self.width).astype(np.float32)
        self._map_v = uv[:, 1].reshape(self.height, self.width).astype(np.float32)

    def to_world(self, view_px) -> np.ndarray:
        """Board coordinates (N, 2) mm of top-down view pixels (N, 2) (column, row)."""
        p = np.asarray(view_px, float).reshape(-1, 2)
        return np.column_stack([self.x_range[0] + p[:, 0] * self.mm_per_px,
                                self.y_range[1] - p[:, 1] * self.mm_per_px])

    def from_world(self, xy) -> np.ndarray:
        """Top-down view pixels (N, 2) (column, row) of board coordinates (N, 2 or 3) mm."""
        p = np.asarray(xy, float).reshape(-1, np.shape(xy)[-1])
        cols = (p[:, 0] - self.x_range[0]) / self.mm_per_px
        rows = (self.y_range[1] - p[:, 1]) / self.mm_per_px
        return np.column_stack([cols, rows])

    def warp(self, rgb) -> np.ndarray:
        """The top-down view (height, width, 3) uint8 of a camera image (lens distortion removed exactly)."""
        rgb = check_rgb(rgb)
        if rgb.shape[:2] != self.camera.image_shape:
            cam = self.camera
            raise ValueError(f"image is {rgb.shape[1]}x{rgb.shape[0]}, camera is {cam.width}x{cam.height}")
        return cv2.remap(rgb, self._map_u, self._map_v, cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT)


def _least_squares_homography(detections, view: BoardView, layout: TagLayout | None = None) -> np.ndarray:
    """The reference path while calib.tag_homography is blank: OpenCV's least-squares fit over the tag centres."""
    layout = layout or lab_config().tags
    ids = sorted(layout.centres_mm)[:4]
    by_id = {d.tag_id: d for d in detections}
    src = np.array([by_id[i].center for i in ids], np.float64)
    dst = view.from_world(np.array([layout.centres_mm[i] for i in ids]))
    return cv2.findHomography(src, dst, 0)[0]


@reference_fallback("calib.tag_homography", _least_squares_homography, "the board homography comes from "
                                                                       "cv2.findHomography")
def tag_homography(detections: list[TagDetection], view: BoardView, layout: TagLayout | None = None) -> np.ndarray:
    """The lab report's method: the 3x3 homography (cv2.getPerspectiveTransform) taking the image centres of the four
    board tags to their places in the top-down view. Ignores lens distortion; use with cv2.warpPerspective.

    Exercise calib.tag_homography (notebook 01: the homography from the image to the board).
    """
    layout = layout or lab_config().tags
    by_id = {d.tag_id: d for d in detections}
    missing = [i for i in sorted(layout.centres_mm) if i not in by_id]
    if missing:
        raise ValueError(f"the four-tag homography needs every board tag; missing ids {missing}")
    ids = sorted(layout.centres_mm)[:4]
    src = np.array([by_id[i].center for i in ids], np.float32)
    dst = view.from_world(np.array([layout.centres_mm[i] for i in ids])).astype(np.float32)
    # BEGIN SOLUTION calib.tag_homography
    return cv2.getPerspectiveTransform(src, dst)
    # END SOLUTION

"""Top-down views of the board: the lab report's four-tag homography, and a distortion-aware rectification.

A top-down view maps board coordinates (x, y) mm on z = 0 to view pixels: column = (x - x_min) / mm_per_px,
row = (y_max - y) / mm_per_px (far side of the board at the top).
"""

from __future__ import annotations

import cv2
import numpy as np

from armlab.calibration.tags import TagDetection
from armlab.camera import Camera
from armlab.images import check_rgb
from armlab.lab import TagLayout, lab_config
from armlab.slots import standin

__all__ = ["BoardView", "tag_homography", "dlt_homography", "opencv_homography"]


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


def opencv_homography(src_px, dst_px) -> np.ndarray:
    """The kit's own homography (3, 3) taking src_px (N, 2) to dst_px (N, 2): OpenCV's least-squares fit
    (cv2.findHomography). The stand-in while calib.tag_homography is blank, and the homography the kit's truths use
    (the camera's pose in calib.tag_extrinsics' reference and checks), never the student's dlt_homography."""
    return cv2.findHomography(np.asarray(src_px, np.float64), np.asarray(dst_px, np.float64), 0)[0]


def _check_correspondences(src, dst) -> tuple[np.ndarray, np.ndarray]:
    src, dst = np.asarray(src, np.float64), np.asarray(dst, np.float64)
    if src.ndim != 2 or src.shape[1] != 2 or src.shape != dst.shape:
        raise ValueError(f"a homography needs two (N, 2) point arrays of the same shape, got {src.shape} and "
                         f"{dst.shape}")
    if len(src) < 4:
        raise ValueError(f"a homography needs at least 4 point pairs, got {len(src)}")
    if not (np.isfinite(src).all() and np.isfinite(dst).all()):
        raise ValueError("the homography's points contain NaN or infinity")
    return src, dst


def _normalising_similarity(points: np.ndarray) -> np.ndarray:
    """Hartley's normalisation: the 3x3 similarity moving `points` (N, 2) to their centroid and scaling them to a
    mean distance of sqrt(2) from it (conditions the DLT's linear system)."""
    centre = points.mean(axis=0)
    spread = np.sqrt(((points - centre) ** 2).sum(axis=1)).mean()
    if spread == 0:
        raise ValueError("the homography's points all coincide")
    s = np.sqrt(2) / spread
    return np.array([[s, 0, -s * centre[0]], [0, s, -s * centre[1]], [0, 0, 1.0]])


@standin("calib.tag_homography", opencv_homography, "homographies come from cv2.findHomography")
def dlt_homography(src, dst) -> np.ndarray:
    """The 3x3 homography H (H[2, 2] = 1) taking the points src (N, 2) to dst (N, 2), N >= 4, any units (pixels,
    mm): the normalised direct linear transform (Hartley & Zisserman, alg. 4.2). Exact for four points in general
    position; the algebraic least-squares fit for more. Raises ValueError for too few, mismatched or degenerate
    points.

    Both point sets are normalised first (T_src, T_dst: _normalising_similarity) so that the linear system is well
    conditioned for coordinates in the hundreds; notebook 01 derives the system and how to undo the normalisation.

    Exercise calib.tag_homography (notebook 01: the homography by the direct linear transform).
    """
    src, dst = _check_correspondences(src, dst)
    T_src, T_dst = _normalising_similarity(src), _normalising_similarity(dst)
    # BEGIN SOLUTION calib.tag_homography
    a = (np.column_stack([src, np.ones(len(src))]) @ T_src.T)[:, :2]
    b = (np.column_stack([dst, np.ones(len(dst))]) @ T_dst.T)[:, :2]
    x, y, u, v = a[:, 0], a[:, 1], b[:, 0], b[:, 1]
    zero, one = np.zeros(len(a)), np.ones(len(a))
    A = np.concatenate([np.column_stack([-x, -y, -one, zero, zero, zero, u * x, u * y, u]),
                        np.column_stack([zero, zero, zero, -x, -y, -one, v * x, v * y, v])])
    H_normalised = np.linalg.svd(A)[2][-1].reshape(3, 3)
    H = np.linalg.solve(T_dst, H_normalised @ T_src)
    # END SOLUTION
    if not np.isfinite(H).all() or abs(H[2, 2]) < 1e-12 * np.abs(H).max():
        raise ValueError("the homography's points are degenerate (three or more on one line?)")
    return H / H[2, 2]


def tag_homography(detections: list[TagDetection], view: BoardView, layout: TagLayout | None = None) -> np.ndarray:
    """The lab report's method: the 3x3 homography (dlt_homography of four point pairs) taking the image centres of
    the four board tags to their places in the top-down view. Ignores lens distortion; use with cv2.warpPerspective.
    """
    layout = layout or lab_config().tags
    by_id = {d.tag_id: d for d in detections}
    missing = [i for i in sorted(layout.centres_mm) if i not in by_id]
    if missing:
        raise ValueError(f"the four-tag homography needs every board tag; missing ids {missing}")
    ids = sorted(layout.centres_mm)[:4]
    src = np.array([by_id[i].center for i in ids], np.float64)
    dst = view.from_world(np.array([layout.centres_mm[i] for i in ids]))
    return dlt_homography(src, dst)

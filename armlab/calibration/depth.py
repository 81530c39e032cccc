"""Depth correction: fit and remove the planar bias a depth camera shows over the flat board.

After the extrinsic, board pixels should read the analytic depth of the plane z = 0; real L515s read a tilted
plane instead (about 20 mm across the image). The bias is modelled as a plane in pixel coordinates,
bias(u, v) = a u + b v + c (mm), fitted robustly on the board's pixels (blocks and the arm are rejected as outliers)
and subtracted from every depth value.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from armlab.arguments import finite_float, instance_of, int_in_range
from armlab.camera import Camera
from armlab.images import check_depth, check_mask
from armlab.lab import lab_config
from armlab.slots import standin

__all__ = ["DepthCorrection", "fit_depth_correction", "board_depth", "board_samples"]

MAX_STEP_PX = 64    # the sparsest sampling of the board's depth that still leaves enough pixels (px)


@dataclass(frozen=True)
class DepthCorrection:
    """bias(u, v) = a u + b v + c in mm; `apply` subtracts it. residual_mm: RMS of the board after correction."""

    a: float = 0.0
    b: float = 0.0
    c: float = 0.0
    residual_mm: float = 0.0
    inliers: int = 0

    def __post_init__(self):
        for name in ("a", "b", "c", "residual_mm"):
            finite_float(getattr(self, name), f"DepthCorrection.{name}", what="mm or mm/px")
        if self.residual_mm < 0:
            raise ValueError(f"DepthCorrection.residual_mm must not be negative, got {self.residual_mm}")
        int_in_range(self.inliers, "DepthCorrection.inliers", 0)

    def bias(self, shape: tuple[int, int]) -> np.ndarray:
        """The bias image (H, W) mm."""
        v, u = np.mgrid[0:shape[0], 0:shape[1]]
        return (self.a * u + self.b * v + self.c).astype(np.float32)

    def apply(self, depth_mm) -> np.ndarray:
        """Corrected depth (H, W) float32 mm (NaN stays NaN)."""
        depth = check_depth(depth_mm)
        return depth - self.bias(depth.shape)

    def span_mm(self, shape: tuple[int, int]) -> float:
        """Largest minus smallest bias over an image of the given shape (mm)."""
        corners = np.array([[0, 0], [shape[1] - 1, 0], [0, shape[0] - 1], [shape[1] - 1, shape[0] - 1]])
        values = self.a * corners[:, 0] + self.b * corners[:, 1] + self.c
        return float(values.max() - values.min())


def board_depth(camera: Camera, step: int = 1) -> tuple[np.ndarray, np.ndarray]:
    """Analytic depth (camera-frame Z, mm) of the plane z = 0 at pixels on a grid of `step` px, and which of them
    fall on the board: returns (depth (H', W'), on_board (H', W'))."""
    instance_of(camera, "camera", Camera)
    step = int_in_range(step, "step", 1, MAX_STEP_PX, "px between samples")
    v, u = np.mgrid[0:camera.height:step, 0:camera.width:step]
    uv = np.column_stack([u.ravel(), v.ravel()]).astype(float)
    world = camera.pixel_to_plane(uv, 0.0)
    depth = camera.depth_of(np.nan_to_num(world)).reshape(u.shape)
    on_board = lab_config().on_board(world[:, :2]).reshape(u.shape) & np.isfinite(world[:, 0]).reshape(u.shape)
    return depth, on_board


def board_samples(depth_mm, camera: Camera, step: int = 4, exclude=None) -> tuple[np.ndarray, ...]:
    """The board's pixels in a depth image, on a grid of `step` px: u, v (H', W') px, measured and expected (the
    plane z = 0 through `camera`) depth (H', W') mm, usable (on the board, with a return, not excluded) and a first
    guess of the inliers (usable and within 30 mm of the median measured - expected: objects on the board read
    nearer). exclude: optional (H, W) bool mask of pixels to ignore. Raises ValueError when fewer than 50 pixels
    are left, or the depth image is not (H, W) float of the camera's size."""
    instance_of(camera, "camera", Camera)
    step = int_in_range(step, "step", 1, MAX_STEP_PX, "px between samples")
    depth = check_depth(depth_mm, camera.image_shape)
    if exclude is not None:
        exclude = check_mask(exclude, camera.image_shape, "exclude")
    expected, on_board = board_depth(camera, step)
    measured = depth[::step, ::step]
    v, u = np.mgrid[0:camera.height:step, 0:camera.width:step]
    usable = on_board & np.isfinite(measured)
    if exclude is not None:
        usable &= ~np.asarray(exclude, bool)[::step, ::step]
    residual = measured - expected
    keep = usable & (np.abs(residual - np.nanmedian(residual[usable]) if usable.any() else 0) < 30.0)
    if keep.sum() < 50:
        raise ValueError(f"only {int(keep.sum())} board pixels have usable depth: is the board in view and the "
                         f"extrinsic right?")
    return u, v, measured, expected, usable, keep


def _robust_plane(depth_mm, camera: Camera, step: int = 4, inlier_mm: float = 6.0, iterations: int = 6,
                  exclude=None) -> DepthCorrection:
    """The reference path while calib.depth_plane is blank: one robust fit of the bias plane over all usable board
    samples (scipy.optimize.least_squares with a Cauchy loss of scale inlier_mm / 3, so blocks and the arm barely
    pull it), instead of refitting and rejecting."""
    from scipy.optimize import least_squares

    inlier_mm = finite_float(inlier_mm, "inlier_mm", positive=True, what="mm")
    u, v, measured, expected, usable, keep = board_samples(depth_mm, camera, step, exclude)
    A = np.column_stack([u[usable], v[usable], np.ones(int(usable.sum()))]).astype(float)
    r = (measured - expected)[usable]
    start = np.array([0.0, 0.0, float(np.median(r))])
    coef = least_squares(lambda c: A @ c - r, start, loss="cauchy", f_scale=inlier_mm / 3,
                         x_scale=[1e-3, 1e-3, 1.0]).x
    fit_residual = (measured - expected) - (coef[0] * u + coef[1] * v + coef[2])
    inliers = usable & (np.abs(fit_residual) < inlier_mm)
    final = fit_residual[inliers]
    return DepthCorrection(float(coef[0]), float(coef[1]), float(coef[2]), float(np.sqrt(np.mean(final**2))),
                           int(inliers.sum()))


@standin("calib.depth_plane", _robust_plane, "the depth's bias plane comes from one robust fit "
                                                         "(scipy least squares, Cauchy loss)")
def fit_depth_correction(depth_mm, camera: Camera, step: int = 4, inlier_mm: float = 6.0,
                         iterations: int = 6, exclude=None) -> DepthCorrection:
    """Fit the planar depth bias over the board.

    Args:
        depth_mm: (H, W) depth image, mm (NaN = no return), of a frame showing the board.
        camera: the calibrated camera (its extrinsic says where the board should be).
        step: pixel stride of the samples used.
        inlier_mm: residuals beyond this from the current fit are outliers (blocks, the arm, dropouts).
        iterations: rounds of refit-and-reject.
        exclude: optional (H, W) bool mask of pixels to ignore (e.g. the arm).
    Raises ValueError when too few board pixels have depth.

    Exercise calib.depth_plane (notebook 01: fit the depth camera's planar bias).
    """
    inlier_mm = finite_float(inlier_mm, "inlier_mm", positive=True, what="mm")
    iterations = int_in_range(iterations, "iterations", 1, 1000)
    u, v, measured, expected, usable, keep = board_samples(depth_mm, camera, step, exclude)
    residual = measured - expected
    A_all = np.column_stack([u.ravel(), v.ravel(), np.ones(u.size)]).astype(float)
    r_all = residual.ravel()
    coef = np.zeros(3)
    # BEGIN SOLUTION calib.depth_plane
    for _ in range(iterations):
        idx = keep.ravel()
        coef, *_ = np.linalg.lstsq(A_all[idx], r_all[idx], rcond=None)
        fit_residual = r_all - A_all @ coef
        keep = usable & (np.abs(fit_residual.reshape(u.shape)) < inlier_mm)
    # END SOLUTION
    final = (r_all - A_all @ coef)[keep.ravel()]
    return DepthCorrection(float(coef[0]), float(coef[1]), float(coef[2]),
                           float(np.sqrt(np.mean(final**2))), int(keep.sum()))

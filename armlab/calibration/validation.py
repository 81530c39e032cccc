"""Calibration validation: world error of pixel + depth -> world at every point of the board's 50 mm grid.

The pixel of each grid point comes from outside the calibration being checked: clicked or detected on a real board,
or projected through the simulator's true camera. Points covered by the arm or a block cannot be checked: find them
with `visible_grid_points` and leave them out. Units: mm (world = board frame), px.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from armlab.camera import Camera
from armlab.images import check_depth, sample_depth

__all__ = ["GridError", "grid_world_error", "visible_grid_points"]


@dataclass(frozen=True)
class GridError:
    """Per grid point: world truth (N, 3) mm, estimate (N, 3) mm, error vectors (N, 3) mm; summary in mm."""

    world: np.ndarray
    estimate: np.ndarray
    error: np.ndarray

    @property
    def norm(self) -> np.ndarray:
        """Euclidean error (N,) mm (NaN where the depth had no return)."""
        return np.linalg.norm(self.error, axis=1)

    @property
    def mean_mm(self) -> float:
        """Mean Euclidean error (mm) over the points with a depth return."""
        return float(np.nanmean(self.norm))

    @property
    def max_mm(self) -> float:
        """Largest Euclidean error (mm) over the points with a depth return."""
        return float(np.nanmax(self.norm))

    def distance_from_centre(self) -> np.ndarray:
        """Distance (N,) mm of each grid point from the centre of the checked points (board plane)."""
        return np.linalg.norm(self.world[:, :2] - self.world[:, :2].mean(axis=0), axis=1)

    def summary(self) -> str:
        """One line: mean and max error (mm), how many points."""
        n = self.norm
        return (f"mean {np.nanmean(n):.2f} mm, max {np.nanmax(n):.2f} mm over {int(np.isfinite(n).sum())} grid "
                f"points")

    def border_growth(self) -> float:
        """Slope (mm of error per 100 mm of distance from the board centre) of a line fitted to error vs distance:
        near 0 when the error does not grow towards the borders."""
        n = self.norm
        ok = np.isfinite(n)
        if ok.sum() < 3:
            raise ValueError(f"border_growth needs at least 3 grid points with depth, got {int(ok.sum())}")
        return float(np.polyfit(self.distance_from_centre()[ok] / 100.0, n[ok], 1)[0])


def _grid(grid_world, grid_uv) -> tuple[np.ndarray, np.ndarray]:
    world = np.asarray(grid_world, float)
    uv = np.asarray(grid_uv, float)
    if world.ndim != 2 or world.shape[1] != 3:
        raise ValueError(f"grid_world must have shape (N, 3) mm, got {world.shape}")
    if uv.ndim != 2 or uv.shape[1] != 2:
        raise ValueError(f"grid_uv must have shape (N, 2) px, got {uv.shape}")
    if len(world) != len(uv):
        raise ValueError(f"grid_world has {len(world)} points but grid_uv has {len(uv)}")
    return world, uv


def grid_world_error(camera: Camera, depth_mm, grid_world, grid_uv, radius: int = 2) -> GridError:
    """World error at known grid points: each pixel grid_uv (N, 2) where the image shows grid point grid_world (N, 3)
    is turned into a world point through `camera` and the depth image (median over a (2r+1)^2 window)."""
    depth = check_depth(depth_mm, camera.image_shape)
    world, uv = _grid(grid_world, grid_uv)
    estimate = camera.pixel_to_world(uv, sample_depth(depth, uv, radius))
    return GridError(world, estimate, estimate - world)


def visible_grid_points(camera: Camera, depth_mm, grid_world, grid_uv, tolerance_mm: float = 40.0,
                        radius: int = 2) -> np.ndarray:
    """Which grid points (N,) bool the depth image really shows: the measured depth at grid_uv lies within
    tolerance_mm of the depth `camera` expects for grid_world. Points under the arm or a block read much nearer (the
    object's height), points without a return read NaN; both are False. The tolerance must exceed the depth bias
    left in depth_mm: 40 mm suits raw depth (bias up to ~25 mm) and finds the arm, not always a 25 mm block; with
    corrected depth (DepthCorrection.apply) 10 mm finds every block."""
    depth = check_depth(depth_mm, camera.image_shape)
    world, uv = _grid(grid_world, grid_uv)
    measured = sample_depth(depth, uv, radius)
    with np.errstate(invalid="ignore"):
        return np.abs(measured - camera.depth_of(world)) < tolerance_mm

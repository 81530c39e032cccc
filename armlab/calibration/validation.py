"""Calibration validation: world error of pixel + depth -> world at every point of the board's 50 mm grid."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from armlab.camera import Camera
from armlab.images import check_depth, sample_depth

__all__ = ["GridError", "grid_world_error"]


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

    def summary(self) -> str:
        n = self.norm
        return f"mean {np.nanmean(n):.2f} mm, max {np.nanmax(n):.2f} mm over {int(np.isfinite(n).sum())} grid points"

    def border_growth(self) -> float:
        """Slope (mm of error per 100 mm of distance from the board centre) of a line fitted to error vs distance:
        near 0 when the error does not grow towards the borders."""
        n = self.norm
        ok = np.isfinite(n)
        centre = self.world[:, :2].mean(axis=0)
        d = np.linalg.norm(self.world[ok, :2] - centre, axis=1)
        return float(np.polyfit(d / 100.0, n[ok], 1)[0])


def grid_world_error(camera: Camera, depth_mm, grid_world, grid_uv, radius: int = 2) -> GridError:
    """World error at known grid points: each pixel grid_uv (N, 2) where the image shows grid point grid_world (N, 3)
    is turned into a world point through `camera` and the depth image (median over a (2r+1)^2 window)."""
    depth = check_depth(depth_mm, camera.image_shape)
    world = np.asarray(grid_world, float).reshape(-1, 3)
    uv = np.asarray(grid_uv, float).reshape(-1, 2)
    if len(world) != len(uv):
        raise ValueError(f"grid_world has {len(world)} points but grid_uv has {len(uv)}")
    estimate = camera.pixel_to_world(uv, sample_depth(depth, uv, radius))
    return GridError(world, estimate, estimate - world)

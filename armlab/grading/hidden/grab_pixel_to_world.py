"""Hidden checks of exercise grab.pixel_to_world: fresh inputs from the grader's seed, compared with the reference's
results (armlab.grading.hidden)."""

from __future__ import annotations

import numpy as np

from . import HiddenSpec
from ._common import _camera_over_board


def _clicks(rng):
    # a small distorted camera, a depth image with noise and dropouts, clicks at fractional pixels, several radii
    cases = []
    for _ in range(3):
        K, T = _camera_over_board(rng, 64, 48)
        dist = [float(rng.uniform(-0.05, 0.05)), float(rng.uniform(-0.02, 0.02)), 0.0, 0.0, 0.0]
        v, u = np.mgrid[0:48, 0:64]
        depth = 1000 + rng.uniform(-0.5, 0.5) * u + rng.uniform(-0.5, 0.5) * v + rng.normal(0, 2, (48, 64))
        depth[rng.random(depth.shape) < 0.1] = np.nan
        calls = [[K, dist, T, depth.tolist(), [float(rng.uniform(6, 57)), float(rng.uniform(6, 41))],
                  int(rng.integers(1, 5))] for _ in range(4)]
        cases.append(calls)
    return cases


def _call_pixel_to_world(function, K, dist, T, depth, uv, radius):
    from armlab.camera import Camera

    camera = Camera(np.asarray(K, float), np.asarray(dist, float), np.asarray(T, float), 64, 48)
    return function(np.asarray(uv, float), np.asarray(depth, float), camera, radius=int(radius))


SPECS: tuple[HiddenSpec, ...] = (HiddenSpec("pixel_to_world", _clicks, atol=1e-6, adapter="_call_pixel_to_world",
                                      prelude="definitions"),)
FORBIDDEN: tuple[str, ...] = (
    "tasks.surface_point", "Camera.pixel_to_world", "Camera.pixel_to_camera"
)

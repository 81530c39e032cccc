"""Inputs several exercises' hidden checks draw: a pinhole camera, a camera over the board."""

from __future__ import annotations

import numpy as np


def _pinhole(rng):
    K = [[900.0 + rng.uniform(-50, 50), 0.0, 640 + rng.uniform(-20, 20)],
         [0.0, 900.0 + rng.uniform(-50, 50), 360 + rng.uniform(-20, 20)], [0.0, 0.0, 1.0]]
    a = rng.uniform(-0.3, 0.3)
    T = [[1.0, 0.0, 0.0, rng.uniform(-50, 50)], [0.0, -np.cos(a), np.sin(a), rng.uniform(100, 200)],
         [0.0, -np.sin(a), -np.cos(a), rng.uniform(900, 1100)], [0.0, 0.0, 0.0, 1.0]]
    return K, T


def _camera_over_board(rng, width=1280, height=720):
    """K (3, 3) for an image of width x height px and T_cam_world (4, 4) of a camera 0.9-1.1 m over the board
    looking at a random board point."""
    from armlab.camera import look_at

    f = width * 0.7 * rng.uniform(0.95, 1.05)
    K = [[f, 0.0, width / 2 + rng.uniform(-0.02, 0.02) * width], [0.0, f, height / 2 + rng.uniform(-0.02, 0.02) *
                                                                  height], [0.0, 0.0, 1.0]]
    T = look_at([rng.uniform(-60, 60), rng.uniform(80, 260), rng.uniform(900, 1100)],
                [rng.uniform(-40, 40), rng.uniform(120, 200), 0.0])
    return K, T.tolist()

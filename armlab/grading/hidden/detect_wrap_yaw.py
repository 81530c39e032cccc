"""Hidden checks of exercise detect.wrap_yaw: fresh inputs from the grader's seed, compared with the reference's
results (armlab.grading.hidden)."""

from __future__ import annotations

import numpy as np

from . import HiddenSpec


def _angles(rng):
    # wide angles, and angles 1e-3 rad either side of the wrap's edges (odd multiples of pi/4)
    edges = [(2 * int(k) + 1) * np.pi / 4 + s * 1e-3 for k in rng.integers(-6, 6, 10) for s in (-1, 1)]
    return [[[float(a)] for a in rng.uniform(-10, 10, 20)], [[float(a)] for a in rng.uniform(-100, 100, 20)],
            [[float(a)] for a in edges]]


SPECS: tuple[HiddenSpec, ...] = (HiddenSpec("wrap_yaw", _angles, atol=1e-9, prelude="definitions"),)
FORBIDDEN: tuple[str, ...] = (
    "transforms.wrap_quarter",
)

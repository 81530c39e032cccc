"""Hidden checks of exercise detect.centroid: fresh inputs from the grader's seed, compared with the reference's
results (armlab.grading.hidden)."""

from __future__ import annotations

import numpy as np

from . import HiddenSpec


def _masks(rng):
    cases = []
    for _ in range(4):
        mask = np.zeros((60, 80), dtype=bool)
        for _ in range(3):
            u, v, w, h = rng.integers(0, 70), rng.integers(0, 50), rng.integers(3, 20), rng.integers(3, 20)
            mask[v:v + h, u:u + w] = True
        cases.append([[mask.astype(int).tolist()]])
    return cases


SPECS: tuple[HiddenSpec, ...] = (HiddenSpec("centroid", _masks, atol=1e-6, prelude="definitions"),)
FORBIDDEN: tuple[str, ...] = (
    "scipy.ndimage.center_of_mass",
)

"""Hidden checks of exercise calib.pixel_to_world_pinhole: fresh inputs from the grader's seed, compared with the
reference's results (armlab.grading.hidden)."""

from __future__ import annotations

from . import HiddenSpec
from ._common import _pinhole


def _back_projections(rng):
    cases = []
    for _ in range(3):
        K, T = _pinhole(rng)
        cases.append([[K, T, [float(rng.uniform(0, 1280)), float(rng.uniform(0, 720))],
                       float(rng.uniform(700, 1200))] for _ in range(4)])
    return cases


SPECS: tuple[HiddenSpec, ...] = (HiddenSpec("pixel_to_world_pinhole", _back_projections, atol=1e-6),)
FORBIDDEN: tuple[str, ...] = (
    "Camera.pixel_to_world", "Camera.pixel_to_camera", "Camera.camera_to_world"
)

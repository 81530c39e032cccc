"""Hidden checks of exercise events.sky_points: fresh inputs from the grader's seed, compared with the reference's
results (armlab.grading.hidden)."""

from __future__ import annotations

from . import HiddenSpec


def _towers(rng):
    return [[[int(n)] for n in rng.integers(0, 7, 4)], [[int(n)] for n in rng.integers(8, 16, 4)], [[8], [9], [0]]]


SPECS: tuple[HiddenSpec, ...] = (HiddenSpec("sky_points", _towers, atol=0),)
FORBIDDEN: tuple[str, ...] = (
    "scoring.sky_points", "score_event", "scoring"
)

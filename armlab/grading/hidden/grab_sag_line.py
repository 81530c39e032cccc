"""Hidden checks of exercise grab.sag_line: fresh inputs from the grader's seed, compared with the reference's
results (armlab.grading.hidden)."""

from __future__ import annotations

from . import HiddenSpec


def _noisy_lines(rng):
    cases = []
    for _ in range(4):
        n = int(rng.integers(6, 30))
        reach = rng.uniform(100, 500, n)
        sag = rng.uniform(-0.2, 0.2) * reach + rng.uniform(-20, 20) + rng.normal(0, rng.uniform(0.1, 3), n)
        cases.append([[reach.tolist(), sag.tolist()]])
    return cases


SPECS: tuple[HiddenSpec, ...] = (HiddenSpec("sag_line", _noisy_lines, atol=1e-8, prelude="definitions"),)
FORBIDDEN: tuple[str, ...] = (
    "scipy.stats.linregress", "scipy.optimize.curve_fit", "Polynomial.fit"
)

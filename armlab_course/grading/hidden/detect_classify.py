"""Hidden checks of exercise detect.classify: fresh inputs from the grader's seed, compared with the reference's
results (armlab_course.grading.hidden)."""

from __future__ import annotations

from . import HiddenSpec


def _colour_models(rng):
    # six classes whose spreads differ tenfold between classes and axes: the nearest mean alone is often wrong
    from armlab.detection.color import COLORS, color_features

    cases = []
    for _ in range(4):
        means = color_features(rng.uniform(20, 235, (6, 3)))
        stds = rng.uniform(0.005, 0.08, (6, 3))
        cases.append([[list(COLORS), means.tolist(), stds.tolist(), rng.uniform(0, 255, (25, 3)).tolist()]])
    return cases


SPECS: tuple[HiddenSpec, ...] = (HiddenSpec("armlab.detection.color.ColorModel", _colour_models, atol=1e-9,
                                  adapter="_call_classify",
                                  what="the classes and their margins"),)
FORBIDDEN: tuple[str, ...] = (
    "ColorModel._nearest_mean",
)

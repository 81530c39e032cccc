"""Hidden checks of exercise detect.segment: fresh inputs from the grader's seed, compared with the reference's
results (armlab.grading.hidden)."""

from __future__ import annotations

import numpy as np

from . import HiddenSpec


def _hsv_boxes(rng):
    # random images and random HSV boxes (red's wrapping around H = 0), labels exact
    cases = []
    for _ in range(3):
        boxes = []
        for name in ("red", "orange", "yellow", "green", "blue", "violet"):
            if name == "red":
                h0, h1 = int(rng.integers(160, 178)), int(rng.integers(3, 12))
            else:
                h0 = int(rng.integers(5, 150))
                h1 = h0 + int(rng.integers(5, 30))
            boxes.append([name, [h0, int(rng.integers(20, 150)), int(rng.integers(20, 150))], [h1, 255, 255]])
        cases.append([[rng.integers(0, 256, (30, 40, 3)).tolist(), boxes]])
    return cases


def _call_segment(function, rgb, boxes):
    ranges = {str(name): (tuple(int(x) for x in lo), tuple(int(x) for x in hi)) for name, lo, hi in boxes}
    return function(np.asarray(rgb, np.uint8), ranges)


def _balanced_faces(rng):
    # white-balanced block faces of the lab's colours, shaded 0.75-1.15 with noise, on a grey board: the student's
    # own tuned ranges through their segmentation must agree with the reference's labels on 90 % of the pixels
    from armlab.blocks import LAB_RGB

    cases = []
    for _ in range(2):
        rows = []
        for colour in LAB_RGB.values():
            shade = rng.uniform(0.75, 1.15, (1, 40, 1))
            rows.append(np.clip(np.array(colour, float) * shade + rng.normal(0, 4, (1, 40, 3)), 0, 255))
        grey = rng.uniform(100, 170, (1, 40, 1)) + rng.normal(0, 3, (1, 40, 3))
        rows.append(np.clip(grey, 0, 255))
        cases.append([[np.concatenate(rows).astype(np.uint8).tolist()]])
    return cases


def _call_segment_tuned(function, rgb):
    """segment_colours with the student's own tuned_hsv_ranges()."""
    return function(np.asarray(rgb, np.uint8), function.__globals__["tuned_hsv_ranges"]())


SPECS: tuple[HiddenSpec, ...] = (HiddenSpec("segment_colours", _hsv_boxes, atol=0, adapter="_call_segment",
                                  prelude="definitions"),
                       HiddenSpec("segment_colours", _balanced_faces, atol=0, adapter="_call_segment_tuned",
                                  prelude="definitions", agree=0.9))
FORBIDDEN: tuple[str, ...] = (
    "ColorModel", "segment_by_colour_model"
)

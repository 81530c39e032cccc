"""Block colour classification: white balance from the board, then nearest class in chromaticity space.

Why not HSV thresholds (the lab report's Table IV)? Their ranges overlap (blue 96-130 and violet 110-141), red wraps
around hue 0 and is missed below 140, and dark blocks (green, blue) have weak saturation that noise scatters. Here:
1. white balance: the board is neutral, so per-channel gains that make the board grey remove the lighting's tint;
2. features: chromaticity (r, g) = (R, G) / (R + G + B) of the face's mean colour, which ignores brightness (shading
   and lighting level), plus a small weight on log brightness to split colours of equal chroma but different
   lightness;
3. a nearest-class rule with per-class spread (a diagonal Mahalanobis distance), calibrated from labelled samples.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from armlab._paths import data_path
from armlab.blocks import COLORS, LAB_RGB
from armlab.files import read_json, write_json_atomic
from armlab.schemas import comment, field_error, number, strict_object, vector
from armlab.slots import standin

__all__ = ["ColorModel", "color_features", "white_balance_gains", "default_color_model", "COLOR_MODEL_FILE",
           "LAB_HSV_TABLE", "hsv_table_classify"]

COLOR_MODEL_FILE = "color_model.json"   # in data/: the calibrated model detect_blocks uses by default

# The lab report's Table IV: OpenCV HSV ranges (H 0-180) per colour, checked in this order, first match wins.
LAB_HSV_TABLE: dict[str, tuple[tuple[int, int, int], tuple[int, int, int]]] = {
    "red": ((140, 30, 100), (180, 255, 255)),
    "orange": ((5, 50, 100), (15, 255, 255)),
    "yellow": ((20, 50, 100), (27, 255, 255)),
    "green": ((39, 50, 100), (94, 255, 255)),
    "blue": ((96, 50, 120), (130, 255, 255)),
    "violet": ((110, 50, 100), (141, 255, 255)),
}

_BRIGHTNESS_WEIGHT = 0.08


def white_balance_gains(board_rgb_mean) -> np.ndarray:
    """Per-channel gains (3,) that turn the board's mean colour (3,) into a neutral grey of the same brightness."""
    m = np.asarray(board_rgb_mean, float)
    if m.shape != (3,) or not np.all(np.isfinite(m)) or np.any(m <= 0):
        return np.ones(3)
    return m.mean() / m


def color_features(rgb_mean) -> np.ndarray:
    """Features (N, 3): chromaticity r, g and weighted log brightness of mean colours (N, 3) (white-balanced RGB)."""
    c = np.asarray(rgb_mean, float).reshape(-1, 3) + 1.0
    s = c.sum(axis=1, keepdims=True)
    return np.column_stack([c[:, :2] / s, _BRIGHTNESS_WEIGHT * np.log(s[:, 0])])


@dataclass(frozen=True)
class ColorModel:
    """Class means (K, 3) and standard deviations (K, 3) of color_features for the class names (K,)."""

    names: tuple[str, ...]
    means: np.ndarray
    stds: np.ndarray

    @staticmethod
    def from_reference(rgb: dict[str, tuple[int, int, int]] | None = None, std: float = 0.03) -> ColorModel:
        """A prior model from reference colours (default: the lab's measured block colours), equal spreads."""
        rgb = rgb or LAB_RGB
        names = tuple(c for c in COLORS if c in rgb)
        means = color_features(np.array([rgb[n] for n in names]))
        return ColorModel(names, means, np.full_like(means, std))

    @staticmethod
    def fit(rgb_means, labels, min_std: float = 0.01) -> ColorModel:
        """Calibrate from labelled samples: mean colours (N, 3) of block faces (white-balanced) and their names."""
        X = color_features(rgb_means)
        labels = np.asarray(labels)
        names = tuple(c for c in COLORS if np.any(labels == c))
        if len(names) < 2:
            raise ValueError("fitting a colour model needs labelled samples of at least two colours")
        means = np.array([X[labels == n].mean(axis=0) for n in names])
        stds = np.array([np.maximum(X[labels == n].std(axis=0), min_std) for n in names])
        return ColorModel(names, means, stds)

    def common_distances(self, rgb_means) -> np.ndarray:
        """Distances (N, K) of mean colours (N, 3) to every class mean in feature space, in units of one spread
        common to every class (the mean of the fitted spreads): the kit's own measure (the BGR check, the stand-ins);
        each class's own spreads are what exercise detect.classify weighs."""
        X = color_features(rgb_means)
        return np.linalg.norm(X[:, None, :] - self.means[None], axis=-1) / float(self.stds.mean())

    def _nearest_mean(self, rgb_means) -> tuple[list[str], np.ndarray]:
        """The reference path while detect.classify is blank: the nearest class mean in feature space with one
        common spread for every class (common_distances), ignoring each class's own; margin: the second-nearest's
        distance minus the nearest's, in those common units."""
        d = self.common_distances(rgb_means)
        ranked = np.sort(d, axis=1)
        margin = ranked[:, 1] - ranked[:, 0] if len(self.names) > 1 else np.full(len(d), np.inf)
        return [self.names[i] for i in d.argmin(axis=1)], margin

    @standin("detect.classify", _nearest_mean, "colours are the nearest class mean, with one spread "
                                                          "for every class")
    def classify(self, rgb_means) -> tuple[list[str], np.ndarray]:
        """Nearest class name per mean colour (N, 3), and the margin (N,): second-best minus best distance.

        Exercise detect.classify (notebook 04: nearest colour class with per-class spreads).
        """
        # BEGIN SOLUTION detect.classify
        X = color_features(rgb_means)
        d = np.sqrt((((X[:, None, :] - self.means[None]) / self.stds[None]) ** 2).sum(-1))
        order = np.argsort(d, axis=1)
        best = [self.names[i] for i in order[:, 0]]
        rows = np.arange(len(d))
        margin = d[rows, order[:, 1]] - d[rows, order[:, 0]] if d.shape[1] > 1 else np.full(len(d), np.inf)
        # END SOLUTION
        return best, margin

    def save(self, path, note: str = "") -> None:
        """Write the model as JSON (atomic: a temporary file in the same folder, then replace)."""
        write_json_atomic(path, {"format": "armlab-color-model/1", "note": note, "names": list(self.names),
                                 "means": self.means.tolist(), "stds": self.stds.tolist()})

    @staticmethod
    def load(path) -> ColorModel:
        """Read a model saved by save(); raises ValueError naming the file and problem."""
        path = Path(path)
        raw = read_json(path, "colour model", schema=SCHEMA)
        k = len(raw["names"])
        for key in ("means", "stds"):
            if len(raw[key]) != k:
                raise field_error(path, key, f"must hold one row per name ({k}), got {len(raw[key])}")
        return ColorModel(tuple(raw["names"]), np.array(raw["means"], float), np.array(raw["stds"], float))


SCHEMA = strict_object({
    "format": {"const": "armlab-color-model/1"}, "note": comment(),
    "names": vector({"enum": list(COLORS)}, min_items=2, max_items=len(COLORS)) | {"uniqueItems": True},
    "means": vector(vector(number(minimum=-1e6, maximum=1e6), 3), min_items=2, max_items=len(COLORS)),
    "stds": vector(vector(number(exclusive_minimum=0.0, maximum=1e6), 3), min_items=2, max_items=len(COLORS))},
    required=("names", "means", "stds"))
"""The declared schema of color_model.json (armlab.schemas): two or more distinct colours, a mean (3,) and a
positive spread (3,) each."""

_DEFAULT: dict[tuple, ColorModel] = {}


def default_color_model() -> ColorModel:
    """The calibrated model of the data folder's color_model.json (armlab._paths.data_path: the packaged file, or a
    lab's own in $ARMLAB_DATA), validated: a missing or corrupt file raises ValueError naming it (never a silent
    fallback to other colours; ColorModel.from_reference() is there to be asked for). Loaded once per file version."""
    path = data_path(COLOR_MODEL_FILE)
    try:
        stamp = path.stat()
    except FileNotFoundError:
        raise ValueError(f"{path}: colour model file not found (refit it with `python -m armlab colors fit`, or "
                         f"pass detection settings with a ColorModel)") from None
    key = (str(path), stamp.st_mtime_ns, stamp.st_size)
    if key not in _DEFAULT:
        _DEFAULT.clear()
        _DEFAULT[key] = ColorModel.load(path)
    return _DEFAULT[key]


def hsv_table_classify(rgb_means, table=None) -> list[str]:
    """The lab report's rule for mean colours (N, 3) RGB: the first colour of the HSV table whose range holds the
    colour (OpenCV HSV, H in 0-180), or "none" when no range does."""
    table = table or LAB_HSV_TABLE
    rgb = np.clip(np.rint(np.asarray(rgb_means, float).reshape(-1, 1, 3)), 0, 255).astype(np.uint8)
    hsv = cv2.cvtColor(rgb, cv2.COLOR_RGB2HSV).reshape(-1, 3).astype(int)
    out = []
    for px in hsv:
        name = next((n for n, (lo, hi) in table.items() if np.all(px >= lo) and np.all(px <= hi)), "none")
        out.append(name)
    return out
